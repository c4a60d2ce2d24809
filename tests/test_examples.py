"""Every example runs to completion in smoke mode, prints numbers and writes its output."""

import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
EXAMPLES = {
    "01_gaussian_circles.py": ["01_gaussian_circles.png"],
    "02_radial_polytope.py": ["02_radial_polytope.png"],
    "03_localize_kitchen.py": ["03_localize_kitchen.png"],
    "04_from_images.py": ["04_from_images.png"],
    "05_compare_solvers.py": ["solver_comparison.md", "solver_comparison.csv"],
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
