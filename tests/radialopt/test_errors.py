"""radialopt's error tree: a bad argument is a ValueError, a failure on valid arguments is not."""

from __future__ import annotations

import numpy as np
import pytest

import radialopt as ro


def test_the_base_and_the_failures_on_valid_arguments_are_not_value_errors() -> None:
    assert not issubclass(ro.RadialError, ValueError)
    assert not issubclass(ro.SolverError, ValueError)
    assert not issubclass(ro.VerificationError, ValueError)
    assert not issubclass(ro.SingularFisherError, ValueError)
    assert issubclass(ro.SolverError, RuntimeError) and issubclass(ro.SolverError, ro.RadialError)
    assert issubclass(ro.RadialArgumentError, ro.RadialError)
    assert issubclass(ro.RadialArgumentError, ValueError)


@pytest.mark.parametrize("call", [
    lambda: ro.GaussianSphere([0.0, 0.0], 1.0, 0.1),
    lambda: ro.GaussianSphere([0.0, 0.0, 0.0], -1.0, 0.1),
    lambda: ro.make_spheres(np.zeros((2, 3)) + [[0, 0, 0], [np.nan, 0, 0]], [1.0, 1.0], 0.1),
    lambda: ro.project_radii(ro.make_spheres([[0, 0, 0], [2, 0, 0]], [1.0, 1.0], 0.1), method="nope"),
    lambda: ro.crlb(np.zeros((0, 3)), np.zeros(0), [0.0, 0.0, 0.0]),
])
def test_a_bad_argument_is_a_radial_error_and_a_value_error(call) -> None:
    with pytest.raises(ro.RadialArgumentError) as info:
        call()
    assert isinstance(info.value, ro.RadialError) and isinstance(info.value, ValueError)


def test_a_singular_geometry_is_a_radial_error_but_no_value_error() -> None:
    centers = np.array([[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]])
    with pytest.raises(ro.SingularFisherError) as info:
        ro.crlb(centers, [0.1, 0.1, 0.1], [0.3, 0.3, 0.0])  # on the centres' plane
    assert isinstance(info.value, ro.RadialError) and not isinstance(info.value, ValueError)
