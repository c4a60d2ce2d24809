"""Every example runs to completion in smoke mode, prints numbers and writes its output."""

import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]
EXAMPLES = {
    "01_gaussian_circles.py": ["01_gaussian_circles.png"],
    "02_radial_polytope.py": ["02_radial_polytope.png"],
    "03_localize_kitchen.py": ["03_localize_kitchen.png"],
    "04_from_images.py": ["04_from_images.png"],
    "05_compare_solvers.py": ["solver_comparison.md", "solver_comparison.csv", "05_compare_solvers.png"],
    "06_robust_ranges.py": ["06_robust_ranges.png"],
    "07_active_validation.py": ["07_active_validation.png"],
}


@pytest.mark.parametrize("script", sorted(EXAMPLES))
def test_example_runs_in_smoke_mode(script, tmp_path):
    args = [sys.executable, str(ROOT / "examples" / script), "--smoke", "--out", str(tmp_path)]
    if script.startswith("05"):
        args += ["--workers", "1", "--no-progress"]
    done = subprocess.run(args, capture_output=True, text=True, timeout=300, cwd=tmp_path)
    assert done.returncode == 0, done.stderr[-2000:]
    assert any(ch.isdigit() for ch in done.stdout)
    for name in EXAMPLES[script]:
        out = tmp_path / name
        assert out.exists() and out.stat().st_size > 100, name
    if script.startswith("05"):
        # the solvers' own console output stays out of the example's
        assert "Running HiGHS" not in done.stdout
        assert "Solution may be inaccurate" not in done.stderr


#: Modules of the ``solvers`` and ``test`` extras that the ``examples`` extra does not bring
#: (cvxpy itself requires OSQP, SCS, Clarabel and HiGHS).
NOT_IN_EXAMPLES_EXTRA = ("ecos", "tqdm", "distributed")

_BLOCKED_RUN = """
import importlib.abc, runpy, sys
blocked = set(sys.argv[1].split(","))
class Block(importlib.abc.MetaPathFinder):
    def find_spec(self, name, path=None, target=None):
        if name.split(".")[0] in blocked:
            raise ModuleNotFoundError(f"No module named {name!r} (blocked)", name=name)
        return None
sys.meta_path.insert(0, Block())
script = sys.argv[2]
sys.path.insert(0, script.rsplit("/", 1)[0])
sys.argv = sys.argv[2:]
runpy.run_path(script, run_name="__main__")
"""


def test_example_05_runs_with_only_the_examples_extra(tmp_path):
    """Without ECOS, tqdm and distributed (as after ``pip install -e ".[examples]"``) example 05
    skips ECOS with a note, runs without a progress bar and still writes its three outputs."""
    script = str(ROOT / "examples" / "05_compare_solvers.py")
    args = [sys.executable, "-c", _BLOCKED_RUN, ",".join(NOT_IN_EXAMPLES_EXTRA), script, "--smoke",
            "--out", str(tmp_path), "--workers", "1"]
    done = subprocess.run(args, capture_output=True, text=True, timeout=300, cwd=tmp_path)
    assert done.returncode == 0, done.stderr[-2000:]
    notes = [line for line in done.stdout.splitlines() if line.startswith("note:")]
    assert any("ECOS" in line and "skipped" in line for line in notes), done.stdout[:1000]
    assert any("tqdm" in line for line in notes), done.stdout[:1000]
    assert "cvxpy:ECOS" not in done.stdout
    assert "cvxpy:CLARABEL" in done.stdout
    for name in EXAMPLES["05_compare_solvers.py"]:
        assert (tmp_path / name).stat().st_size > 100, name
