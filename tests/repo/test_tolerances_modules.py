"""One tolerances module per package (docs/design.md#tolerances): the moved names still import
from their old homes, the values are the ones the code had, and no new tolerance literal
appears outside the tolerances modules."""

from __future__ import annotations

import re
import tokenize
from collections import Counter
from pathlib import Path

import perception.tolerances as ptol
import radialopt
import radialopt.tolerances as rtol
import worldgraph.tolerances as wtol

ROOT = Path(__file__).resolve().parents[2]
SMALL = re.compile(r"^[0-9.]+e-[0-9]+$", re.IGNORECASE)

#: Literals that stay in the code, with the reason (the tolerances modules say the same).
ALLOWED: dict[str, list[str]] = {
    # input range bound of sigmas relative to the length scale (a domain limit, used by the
    # validators that the tolerances module itself imports)
    "radialopt/_checks.py": ["1e-12"],
    # timing shift, a generated problem's physical sigma floor (m), a time unit (s)
    "radialopt/comparison.py": ["1e-3", "1e-3", "1e-3"],
    # EstimatorOptions field defaults: user options next to the iteration budgets they go with
    "radialopt/_estimator_options.py": ["1e-9", "1e-12", "1e-13", "1e-13", "1e-6", "1e-9"],
    # input range of percept sigmas (SIGMA_RANGE, m)
    "worldgraph/association/consistency.py": ["1e-12"],
    # input range of depth_factor (1/m); the physical min_sigma default (m)
    "worldgraph/active/plan.py": ["1e-3"],
    "worldgraph/active/predict.py": ["1e-4"],
    # a rendered plane's physical thickness (m)
    "worldgraph/importers/franka.py": ["1e-3"],
    # input ranges of pose weights and covariance eigenvalues (the messages quote them)
    "worldgraph/pose/frames.py": ["1e-150", "1e-100"],
    # input ranges of sigmas and variances
    "perception/frontend/fusion.py": ["1e-150", "1e-300"],
    # input range of covariance entries; the classifier's regularisation default (a user option)
    "perception/recognition/classifier.py": ["1e-150", "1e-4"],
    # input range of sigmas; physical min_sigma defaults (m)
    "perception/simulation/simulate.py": ["1e-150", "1e-4", "1e-4"],
    # the physical depth-noise default of a depth camera (1/m)
    "perception/frontend/detection_percepts.py": ["1.5e-3"],
    # input ranges of the field of view (degrees) and of the default rig's baseline (m)
    "perception/head/stereo.py": ["1e-6", "1e-6"],
    # the differentiation step default (pixels, a user-facing size) and its input range
    "perception/head/uncertainty.py": ["1e-3", "1e-9"],
}
#: Files another branch is rewriting while this one was written: not scanned.
NOT_SCANNED: set[str] = set()


def _small_literals(path: Path) -> list[str]:
    """The ``1e-N`` number tokens of a file (strings, docstrings and comments are other tokens)."""
    with path.open(encoding="utf-8") as fh:
        return [t.string for t in tokenize.generate_tokens(fh.readline)
                if t.type == tokenize.NUMBER and SMALL.match(t.string)]


def test_no_tolerance_literals_outside_the_tolerances_modules() -> None:
    found = {}
    for pkg in ("radialopt", "worldgraph", "perception"):
        for path in sorted((ROOT / pkg).rglob("*.py")):  # subpackages too
            rel = path.relative_to(ROOT).as_posix()
            if path.name == "tolerances.py" or rel in NOT_SCANNED:
                continue
            lits = _small_literals(path)
            if lits:
                found[rel] = Counter(lits)
    assert found == {k: Counter(v) for k, v in ALLOWED.items()}


def test_the_scanner_sees_a_literal_and_ignores_strings(tmp_path: Path) -> None:
    f = tmp_path / "m.py"
    f.write_text('"""1e-9 in a docstring"""\nx = 1e-9  # 1e-6 in a comment\ny = "1e-3"\nz = 1.5e-12\n')
    assert _small_literals(f) == ["1e-9", "1.5e-12"]


def test_old_import_paths_are_the_moved_objects() -> None:
    from radialopt.conformal import MEET_TOLERANCES, MeetTolerances
    from radialopt.projection import CLARABEL_TIGHT, SOLVER_OPTIONS
    from radialopt.spheres import TOLERANCES, Tolerances
    from radialopt.vertices import VERTEX_TOLERANCES, VertexTolerances
    from worldgraph.pose import COLLINEAR_TOL
    from worldgraph.pose.certificate import CLARABEL_OPTIONS

    assert Tolerances is rtol.Tolerances is radialopt.Tolerances
    assert TOLERANCES is rtol.TOLERANCES is radialopt.TOLERANCES
    assert VertexTolerances is rtol.VertexTolerances and VERTEX_TOLERANCES is rtol.VERTEX_TOLERANCES
    assert MeetTolerances is rtol.MeetTolerances is radialopt.MeetTolerances
    assert MEET_TOLERANCES is rtol.MEET_TOLERANCES is radialopt.MEET_TOLERANCES
    assert CLARABEL_TIGHT is rtol.CLARABEL_TIGHT and SOLVER_OPTIONS is rtol.SOLVER_OPTIONS
    assert COLLINEAR_TOL is wtol.COLLINEAR_TOL and CLARABEL_OPTIONS is wtol.CLARABEL_OPTIONS


def test_values_are_unchanged() -> None:
    """The defaults as the code had them before the move (typed from the old sources)."""
    assert (rtol.TOLERANCES.coincident, rtol.TOLERANCES.feasibility, rtol.TOLERANCES.agreement) == (
        1e-9, 1e-9, 1e-6)
    v = rtol.VERTEX_TOLERANCES
    assert (v.feasibility, v.active, v.zero, v.singular, v.merge) == (1e-9, 1e-9, 1e-10, 1e-10, 1e-10)
    m = rtol.MEET_TOLERANCES
    assert (m.tangent, m.coincident, m.collinear, m.coplanar) == (1e-10, 1e-12, 1e-9, 1e-9)
    assert rtol.CLARABEL_TIGHT == {"tol_gap_abs": 1e-10, "tol_gap_rel": 1e-10, "tol_feas": 1e-10,
                                   "tol_ktratio": 1e-8}
    assert rtol.CERTIFICATE_ROUNDING == 1e-11 and rtol.TINY == 1e-300
    assert wtol.RIGID_TOLERANCE == 1e-6 and wtol.COLLINEAR_TOL == 1e-9
    assert wtol.CERTIFICATE_ROUNDING == 4e-13 and wtol.SIGNIFICANCE == 1e-3
    assert (ptol.SPD_RTOL, ptol.SYM_RTOL, ptol.QUERY_SLACK, ptol.UNDISTORT_EPS, ptol.AXIS_TOL) == (
        1e-14, 1e-8, 1e-9, 1e-15, 1e-9)


def test_every_constant_has_a_comment() -> None:
    """Each module constant of a tolerances module is preceded by a ``#:`` comment line."""
    for mod in (rtol, wtol, ptol):
        lines = Path(mod.__file__).read_text(encoding="utf-8").splitlines()
        for k, line in enumerate(lines):
            if re.match(r"^[A-Z][A-Z0-9_]* = ", line) and not line.endswith("Tolerances()"):
                assert lines[k - 1].startswith("#:"), (mod.__name__, line)
