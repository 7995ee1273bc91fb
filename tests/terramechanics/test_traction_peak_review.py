"""The saturation fraction of :func:`traction_peak` (review tests)."""

from __future__ import annotations

import pytest

from terrain.errors import ConfigError
from terrain.terramechanics import get_terrain
from terrain.terramechanics.traction import traction_peak


@pytest.mark.parametrize("saturation", [95.0, 1.5, 0.0, -0.5, float("nan"), "0.95", None])
def test_traction_peak_refuses_a_saturation_that_is_not_a_fraction_in_0_1(saturation):
    # before: GRASS (a monotone Janosi curve) with saturation 95 (a percentage) or 1.5 gave
    # TractionPeak(slip=0.0, mu=0.0, ...): no grid slip reaches 95 x the maximum, and argmax
    # of an all-False mask is index 0, read as "the curve saturates at zero slip"
    with pytest.raises(ConfigError, match="saturation"):
        traction_peak(get_terrain("GRASS").curve, saturation)


def test_traction_peak_with_saturation_1_is_the_first_slip_at_the_maximum():
    peak = traction_peak(get_terrain("GRASS").curve, 1.0)
    assert peak.monotonic and peak.mu == peak.mu_max and 0.0 < peak.slip <= 1.0
