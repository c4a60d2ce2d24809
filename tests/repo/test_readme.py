"""README.md runs as written: every ```python block, in order, in one namespace, and so
does the tour of the API in docs/tour.md (moved there from the README); the README's two
set-up commands and its documentation command are the ones .ci/run runs."""

from __future__ import annotations

import importlib.util
import os
import re
import shlex
import traceback
from pathlib import Path

import matplotlib
import pytest

ROOT = Path(__file__).resolve().parents[2]
README = ROOT / "README.md"
TOUR = ROOT / "docs" / "tour.md"
OWN_DATA = ROOT / "docs" / "your_own_data.md"
CI_RUN = ROOT / ".ci" / "run"
FENCE = re.compile(r"^```(\w*)[ \t]*\n(.*?)^```[ \t]*$", re.MULTILINE | re.DOTALL)


def fenced_blocks(text: str, language: str) -> list[tuple[int, str]]:
    """``(line number, source)`` of every fenced block of ``language`` in a Markdown text, in order."""
    return [(text.count("\n", 0, m.start()) + 1, m.group(2)) for m in FENCE.finditer(text)
            if m.group(1) == language]


def first_line(source: str) -> str:
    """The first line of a block that is not blank."""
    return next((line.strip() for line in source.splitlines() if line.strip()), "")


def run_blocks(blocks: list[tuple[int, str]], namespace: dict) -> None:
    """Execute the blocks in order in ``namespace``; fail naming the block number, its README line
    and its first line when one raises."""
    for number, (line, source) in enumerate(blocks, start=1):
        code = compile(source, f"README.md python block {number} (line {line})", "exec")
        try:
            exec(code, namespace)  # noqa: S102 - running the README's own code is the point of this test
        except Exception:  # noqa: BLE001 - any failure of the README's code fails the test, named
            pytest.fail(f"README.md python block {number} (line {line}, starting {first_line(source)!r}) "
                        f"raised:\n{traceback.format_exc()}", pytrace=False)


def test_fence_parser_finds_blocks_in_order() -> None:
    text = "intro\n```python\na = 1\n```\n\n```bash\nls\n```\n```python\nb = a + 1\n```\n"
    assert fenced_blocks(text, "python") == [(2, "a = 1\n"), (9, "b = a + 1\n")]
    assert fenced_blocks(text, "bash") == [(6, "ls\n")]


def test_runner_names_the_failing_block() -> None:
    blocks = [(3, "x = 1\n"), (10, "\n# second\ny = undefined_name\n")]
    expected = r"(?s)block 2 \(line 10, starting '# second'\).*NameError"
    with pytest.raises(pytest.fail.Exception, match=expected):
        run_blocks(blocks, {})


def _run_page(page: Path, tmp_path: Path, monkeypatch: pytest.MonkeyPatch, at_least: int) -> None:
    blocks = fenced_blocks(page.read_text(encoding="utf-8"), "python")
    assert len(blocks) >= at_least, f"{page.name} lost its python blocks"
    matplotlib.use("Agg")
    monkeypatch.chdir(tmp_path)  # the tour writes out/ and a temporary scene file
    namespace: dict = {"__name__": "__readme__"}
    try:
        run_blocks(blocks, namespace)
    finally:
        import matplotlib.pyplot as plt

        plt.close("all")


def test_readme_python_blocks_run_in_order(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    _run_page(README, tmp_path, monkeypatch, at_least=1)


def test_the_tour_of_the_api_runs_in_order(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    _run_page(TOUR, tmp_path, monkeypatch, at_least=5)
    # the tour saved its figure where it says
    assert (tmp_path / "out" / "readme_top_view.png").stat().st_size > 0


def test_the_your_own_data_page_runs_in_order(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    # found, not imported: the page sets MUJOCO_GL before MuJoCo loads, as a user's script would
    needed = (("mujoco", "the mujoco extra"), ("gymnasium_robotics", "the Franka kitchen's files"))
    for package, what in needed:
        if importlib.util.find_spec(package) is None:  # installed by the test set-up
            pytest.skip(f"{package} ({what}) not installed")
    _run_page(OWN_DATA, tmp_path, monkeypatch, at_least=8)
    assert (tmp_path / "kitchen.glb").stat().st_size > 0  # the page wrote its map where it says


# ---- the set-up commands -------------------------------------------------------------------------
def commands(text: str) -> list[list[str]]:
    """Simple commands of a shell text: split on newlines, ``&&``, ``;`` and ``|``, comments dropped,
    ``sudo`` and ``python -m`` prefixes removed (``python -m pip`` is ``pip``)."""
    out = []
    for line in text.splitlines():
        words = shlex.split(line, comments=True)
        cmd: list[str] = []
        for w in [*words, "&&"]:
            if w in ("&&", ";", "|", "||"):
                if cmd:
                    while cmd and cmd[0] == "sudo":
                        cmd = cmd[1:]
                    if cmd[:2] == ["python", "-m"] and len(cmd) > 2 and cmd[2] in ("pip", "pytest"):
                        cmd = cmd[2:]
                    out.append(cmd)
                cmd = []
            else:
                cmd.append(w)
    return out


SETUP = ("apt-get", "pip", "pytest")


def setup_commands(cmds: list[list[str]]) -> list[list[str]]:
    """The set-up and test commands (``apt-get``, ``pip``, ``pytest``), in order."""
    return [c for c in cmds if c[0] in SETUP]


def test_command_splitter() -> None:
    text = 'sudo apt-get update && python -m pip install -e ".[test]"  # note\npython -m pytest -q | cat'
    assert commands(text) == [["apt-get", "update"], ["pip", "install", "-e", ".[test]"], ["pytest", "-q"],
                              ["cat"]]
    assert setup_commands(commands(text)) == commands(text)[:3]


def test_readme_setup_commands_are_what_ci_runs() -> None:
    text = README.read_text(encoding="utf-8")
    setup = re.search(r"^## Set-up.*?(?=^## )", text, re.MULTILINE | re.DOTALL)
    assert setup, "README.md has no '## Set-up' section"
    bash = fenced_blocks(setup.group(0), "bash")
    assert len(bash) == 2, f"README.md's set-up has {len(bash)} bash blocks, not its two commands"
    install_and_example, tests = (commands(source) for _, source in bash)
    ci_text = CI_RUN.read_text(encoding="utf-8")
    ci = commands(ci_text)
    ci_setup = setup_commands(ci)
    # README command 1 installs the package from this checkout with the examples extra and runs the
    # example the README names, which exists; CI runs it first, as written
    example_setup = setup_commands(install_and_example)
    assert example_setup == [["pip", "install", "-e", ".[examples]"]]
    runs = [c for c in install_and_example if c[0] == "python"]
    assert len(runs) == 1 and (ROOT / runs[0][1]).is_file()
    assert ci_setup[:1] == example_setup and runs[0] in ci, "CI runs README command 1 as written"
    # README command 2 is CI's job: the same apt-get, pip install and pytest lines, in the same order,
    # followed by the README's documentation build
    docs = re.search(r"^## Documentation.*?(?=^## )", text, re.MULTILINE | re.DOTALL)
    assert docs, "README.md has no '## Documentation' section"
    (docs_block,) = (commands(source) for _, source in fenced_blocks(docs.group(0), "bash"))
    test_setup = setup_commands(tests)
    assert ci_setup[1:1 + len(test_setup)] == test_setup, "CI runs README command 2 as written"
    assert [c[0] for c in ci_setup].count("pytest") == 1
    ci_docs = [c for c in ci if c[:4] == ["python", "-m", "sphinx", "-W"]]
    readme_docs = [c for c in docs_block if c[0] == "python"]
    assert ci_docs and ci_docs == readme_docs, "CI builds the docs as the README says"
    editable = [c for c in ci_setup if c[:3] == ["pip", "install", "-e"]]
    assert [c[3] for c in editable] == [".[examples]", ".[test]", ".[docs]"]
    # each README command starts in a virtual environment of CI's own, made just before it
    lines = ci_text.splitlines()
    starts = [i for i, line in enumerate(lines) if line.startswith("fresh_venv ")]
    first_of = [next(i for i, line in enumerate(lines) if line.startswith(start))
                for start in ("python -m pip install -e", "apt-get")]
    assert len(starts) == 2 and starts[0] < first_of[0] < starts[1] < first_of[1], \
        "each README command runs in its own fresh virtual environment"


def test_ci_run_is_executable() -> None:
    assert os.access(CI_RUN, os.X_OK)


def test_where_things_live_names_every_public_module() -> None:
    """The README's map of the tree names each documented module by its file (``world.py``) or,
    for a package, its folder (``tiles/``), so a newcomer finds every room from it."""
    from tests.public_api import PACKAGES, modules

    text = README.read_text(encoding="utf-8")
    start = text.index("## Where things live")
    block = text[start:text.index("\n## ", start + 1)]
    missing = []
    for name in modules():
        if name in PACKAGES:
            continue
        leaf = name.rpartition(".")[2]
        is_package = (ROOT / Path(*name.split("."))).is_dir()
        ending = "/" if is_package else r"\.py"
        if not re.search(r"(?<![\w/])" + re.escape(leaf) + ending, block):
            missing.append(name)
    assert missing == []
