"""Review tests (tm5) of calibration, bearing capacity and their inputs."""

from __future__ import annotations

import pytest

from terrain.errors import ConfigError
from terrain.terramechanics import get_terrain
from terrain.terramechanics.calibration import husky_hysteresis_for_current, steady_slip
from terrain.terramechanics.lateral import bearing_capacity_factors


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


def test_bearing_capacity_factors_are_the_cited_closed_forms():
    # N_q = e^(pi tan phi) tan^2(45 + phi/2), N_c = (N_q - 1) cot phi, N_gamma = 2 (N_q + 1)
    # tan phi (Vesic 1973), as the docstring cites them; tabulated (Das, Principles of
    # Foundation Engineering, Vesic's table) at 29 deg: 27.86, 16.44, 19.34
    n_c, n_q, n_g = bearing_capacity_factors(29.0)
    assert (n_c, n_q, n_g) == pytest.approx((27.86, 16.44, 19.34), abs=0.01)


@pytest.mark.parametrize("phi", [0.0, -10.0, 90.0, 120.0, float("nan"), float("inf"), True,
                                 "29", None])
def test_bearing_capacity_factors_refuse_an_angle_outside_0_90(phi):
    # phi = 0 gave N_c = -inf (0 / tan 0 after rounding), a negative angle negative factors,
    # 90 infinite ones, NaN NaN, all without a word; True was 1 degree
    with pytest.raises(ConfigError, match="friction_angle_deg"):
        bearing_capacity_factors(phi)


@pytest.mark.parametrize("demand", [True, "0.1", None])
def test_steady_slip_refuses_a_demand_that_is_not_a_real_number(demand):
    # True was a demand of 1 (slip 1.0, full spin, on every terrain), '0.1' and None a bare
    # TypeError inside math.isfinite
    with pytest.raises(ConfigError, match="extra_demand"):
        steady_slip(get_terrain("SANDY_LOAM"), demand)
