"""The MJCF importer's orientations (scipy's Rotation underneath) against explicit formulas."""

from __future__ import annotations

import math

import numpy as np
import pytest

from worldgraph.importers.franka import _axis_angle_matrix, _euler_matrix, _quat_matrix

RNG_SEED = 20261204


def explicit_axis_rotation(axis: str, angle: float) -> np.ndarray:
    c, s = math.cos(angle), math.sin(angle)
    return {"x": np.array([[1.0, 0, 0], [0, c, -s], [0, s, c]]),
            "y": np.array([[c, 0, s], [0, 1.0, 0], [-s, 0, c]]),
            "z": np.array([[c, -s, 0], [s, c, 0], [0, 0, 1.0]])}[axis]


def explicit_quaternion(q: np.ndarray) -> np.ndarray:
    w, x, y, z = q / np.linalg.norm(q)
    return np.array([
        [1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)],
        [2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)],
        [2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)],
    ])


def test_quaternions_are_scalar_first_and_normalised() -> None:
    h = math.sqrt(0.5)
    quarter_turns = {(h, h, 0.0, 0.0): [[1, 0, 0], [0, 0, -1], [0, 1, 0]],
                     (h, 0.0, h, 0.0): [[0, 0, 1], [0, 1, 0], [-1, 0, 0]],
                     (h, 0.0, 0.0, h): [[0, -1, 0], [1, 0, 0], [0, 0, 1]]}
    for q, R in quarter_turns.items():
        np.testing.assert_allclose(_quat_matrix(np.array(q)), R, atol=1e-15)
        np.testing.assert_allclose(_quat_matrix(3.0 * np.array(q)), R, atol=1e-15)
    rng = np.random.default_rng(RNG_SEED)
    for q in rng.normal(size=(200, 4)) * rng.uniform(0.01, 100.0, (200, 1)):
        np.testing.assert_allclose(_quat_matrix(q), explicit_quaternion(q), atol=1e-13)


def test_a_zero_quaternion_is_a_value_error() -> None:
    with pytest.raises(ValueError):
        _quat_matrix(np.zeros(4))


def test_axis_angle_is_rodrigues_with_the_axis_normalised() -> None:
    rng = np.random.default_rng(RNG_SEED)
    for axis, angle in zip(rng.normal(size=(200, 3)) * 5.0, rng.uniform(-7.0, 7.0, 200), strict=True):
        a = axis / np.linalg.norm(axis)
        k = np.array([[0, -a[2], a[1]], [a[2], 0, -a[0]], [-a[1], a[0], 0]])
        want = np.eye(3) + math.sin(angle) * k + (1 - math.cos(angle)) * (k @ k)
        np.testing.assert_allclose(_axis_angle_matrix(axis, float(angle)), want, atol=1e-13)


@pytest.mark.parametrize("seq", ["xyz", "zyx", "xyx", "zxz", "XYZ", "ZYX", "XYX", "xYz"])
def test_euler_lower_case_is_intrinsic_and_any_other_extrinsic(seq: str) -> None:
    rng = np.random.default_rng(RNG_SEED)
    for angles in rng.uniform(-math.pi, math.pi, (100, 3)):
        want = np.eye(3)
        for ax, ang in zip(seq.lower(), angles, strict=True):
            step = explicit_axis_rotation(ax, float(ang))
            want = want @ step if seq.islower() else step @ want
        np.testing.assert_allclose(_euler_matrix(seq, angles), want, atol=1e-13)


@pytest.mark.parametrize("seq", ["xxy", "xy", "abc"])
def test_an_euler_sequence_that_is_not_three_axes_is_a_value_error(seq: str) -> None:
    with pytest.raises(ValueError):
        _euler_matrix(seq, np.zeros(3))
