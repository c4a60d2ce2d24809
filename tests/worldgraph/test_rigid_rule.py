"""One rigidity rule for the three packages: ``perception.head.chain.rotation_errors`` /
``rotation_defect`` / ``rigid_defect``, used by ``perception.check_transform`` and by worldgraph's
transform and rotation checks.  Checked against a slow, obvious reference (a loop over the
definition with SVD singular values) and for agreement of the two packages' checks."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st
from scipy.spatial.transform import Rotation

import perception as pc
import worldgraph as wg
from perception.head.chain import rigid_defect, rotation_defect, rotation_errors
from perception.tolerances import RIGID_TOLERANCE
from worldgraph._rigid import rigid_transform

TOL = RIGID_TOLERANCE


def _proper_reference(R: np.ndarray, tol: float) -> bool:
    """The definition, spelled out: every entry of R^T R - I and det R - 1 within tol."""
    gram = [[sum(R[k, i] * R[k, j] for k in range(3)) for j in range(3)] for i in range(3)]
    orth = max(abs(gram[i][j] - (1.0 if i == j else 0.0)) for i in range(3) for j in range(3))
    det = (R[0, 0] * (R[1, 1] * R[2, 2] - R[1, 2] * R[2, 1])
           - R[0, 1] * (R[1, 0] * R[2, 2] - R[1, 2] * R[2, 0])
           + R[0, 2] * (R[1, 0] * R[2, 1] - R[1, 1] * R[2, 0]))
    return orth <= tol and abs(det - 1.0) <= tol


def _perturbed(seed: int, scale: float) -> np.ndarray:
    rng = np.random.default_rng(seed)
    R = Rotation.random(random_state=rng).as_matrix()
    return R + scale * rng.standard_normal((3, 3))


@pytest.mark.parametrize("scale", [0.0, 1e-9, 1e-7, 3e-7, 1e-6, 3e-6, 1e-3])
def test_the_vectorised_rule_is_the_definition(scale: float) -> None:
    stack = np.stack([_perturbed(seed, scale) for seed in range(40)])
    orth, det, improper = rotation_errors(stack, TOL)
    expected = np.array([not _proper_reference(R, TOL) for R in stack])
    np.testing.assert_array_equal(improper, expected)
    np.testing.assert_allclose(det, np.linalg.det(stack), rtol=1e-12)
    if scale == 0.0:
        assert not improper.any() and orth.max() < 1e-12
    if scale == 1e-3:
        assert improper.all()


def test_reflections_scales_and_huge_entries_are_named() -> None:
    R = Rotation.from_euler("z", 0.4).as_matrix()
    assert rotation_defect(R, TOL) is None
    assert rotation_defect(R @ np.diag([1.0, 1.0, -1.0]), TOL).startswith("is a reflection: det R = -1")
    assert rotation_defect(1.01 * R, TOL).startswith("is scaled or sheared: det R = 1.0303")
    assert rotation_defect(1e200 * R, TOL) == "has entries up to 1e+200, which no rotation has"
    orth, det, improper = rotation_errors(np.stack([R, 1e200 * R, np.full((3, 3), np.nan)]), TOL)
    np.testing.assert_array_equal(improper, [False, True, True])
    assert np.isinf(orth[1])
    assert rotation_errors(np.zeros((0, 3, 3)), TOL)[2].shape == (0,)


def test_rigid_defect_names_the_part() -> None:
    M = np.eye(4)
    M[:3, :3] = Rotation.from_euler("xyz", [0.1, 0.2, 0.3]).as_matrix()
    M[:3, 3] = [1.0, -2.0, 3.0]
    assert rigid_defect(M, TOL) is None
    row = M.copy()
    row[3, 0] = 1e-3
    assert rigid_defect(row, TOL) == ("last row", "its last row must be [0, 0, 0, 1], got "
                                                  "[0.001, 0.0, 0.0, 1.0]")
    flip = M.copy()
    flip[:3, 0] *= -1.0
    where, why = rigid_defect(flip, TOL)
    assert where == "rotation" and why.startswith("its rotation block is a reflection")


@given(seed=st.integers(0, 2**32 - 1), exponent=st.floats(-10.0, -3.0), row=st.booleans())
def test_perception_and_worldgraph_accept_the_same_transforms(seed: int, exponent: float, row: bool) -> None:
    rng = np.random.default_rng(seed)
    M = np.eye(4)
    M[:3, :3] = _perturbed(seed, 10.0**exponent)
    M[:3, 3] = rng.uniform(-5.0, 5.0, 3)
    if row:
        M[3, rng.integers(0, 4)] += 10.0**exponent
    try:
        pc.check_transform("T", M)
        perception_ok = True
    except pc.PerceptionError:
        perception_ok = False
    try:
        rigid_transform("T", M)
        worldgraph_ok = True
    except wg.WorldGraphError:
        worldgraph_ok = False
    assert perception_ok == worldgraph_ok
    reference = _proper_reference(M[:3, :3], TOL) and np.abs(M[3] - [0, 0, 0, 1]).max() <= TOL
    assert perception_ok == reference
