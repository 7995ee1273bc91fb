"""Review revtm: edges of the shear-mobilisation law and of the stable-side inverse."""

from __future__ import annotations

import numpy as np
import pytest

from terrain.errors import ConfigError
from terrain.terramechanics import get_terrain
from terrain.terramechanics.inverse import slip_from_traction, stable_side
from terrain.terramechanics.traction import patch_mobilisation


@pytest.mark.parametrize("bad", ["abc", "0.5", [0.2, 0.3], object()], ids=repr)
def test_patch_mobilisation_refuses_a_residual_ratio_that_is_not_a_number(bad):
    # float('abc') raised a bare ValueError, float([0.2, 0.3]) a bare TypeError, naming no
    # argument; '0.5' was parsed as a number
    with pytest.raises(ConfigError,
                       match=r"patch_mobilisation.residual_ratio must be a real number"):
        patch_mobilisation(np.array([0.1, 1.0]), bad)


def test_patch_mobilisation_keeps_a_numpy_residual_ratio():
    # NumPy scalars are numbers: the same answer as the Python float
    a = np.linspace(0.0, 5.0, 11)
    for got, want in zip(patch_mobilisation(a, np.float64(0.4)), patch_mobilisation(a, 0.4)):
        np.testing.assert_array_equal(got, want)


@pytest.mark.parametrize("sign", [1.0, -1.0])
def test_an_infinite_traction_is_saturated_at_the_peak_slip(sign):
    curve = get_terrain("ASPHALT").curve
    got = slip_from_traction(curve, sign * np.inf)
    assert bool(got.saturated)
    assert float(got.slip) == sign * stable_side(curve)[0][-1]
