"""Review tests (tm5) of calibration, bearing capacity and their inputs."""

from __future__ import annotations

import pytest

from terrain.errors import ConfigError
from terrain.terramechanics import get_terrain
from terrain.terramechanics.calibration import husky_hysteresis_for_current


@pytest.mark.parametrize("current", [float("nan"), float("inf"), -float("inf"), True, "3.9",
                                     None])
def test_hysteresis_calibration_refuses_a_current_that_is_not_a_finite_number(current):
    # NaN came out as hysteresis 0.0 (max(0.0, nan)), inf as inf and True as a 1 A target,
    # each without a word; a catalogue entry calibrated from a missing measurement
    with pytest.raises(ConfigError, match="current_a"):
        husky_hysteresis_for_current(get_terrain("SANDY_LOAM"), current, 0.45)


def test_hysteresis_calibration_refuses_a_boolean_speed():
    # True passed 'finite and > 0' as a 1 m/s speed
    with pytest.raises(ConfigError, match="speed_m_s"):
        husky_hysteresis_for_current(get_terrain("SANDY_LOAM"), 3.9, True)


def test_hysteresis_below_the_traction_current_is_zero_not_negative():
    # documented: >= 0 (a target below the no-load plus traction current buys no loss)
    assert husky_hysteresis_for_current(get_terrain("SANDY_LOAM"), 0.0, 0.45) == 0.0
