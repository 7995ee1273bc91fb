"""Review tests of the traction controller's settings (terrain.control.traction)."""

from __future__ import annotations

import math

import pytest

from terrain.control.traction import TractionControlConfig
from terrain.errors import ConfigError


@pytest.mark.parametrize("kwargs, named", [
    ({"output_fraction": 0.0}, "output_fraction"),     # a limit of 0: the PID could never act
    ({"output_fraction": -0.5}, "output_fraction"),
    ({"kp": math.inf}, "kp=inf"), ({"ki": math.inf}, "ki=inf"), ({"kd": -math.inf}, "kd=-inf"),
    ({"kp": math.nan}, "kp=nan"), ({"omega_max_rad_s": math.inf}, "omega_max_rad_s=inf"),
    ({"max_input_age_s": math.inf}, "max_input_age_s=inf"),
    ({"wheel_speed_threshold_m_s": -0.01}, "thresholds"),
    ({"chassis_speed_threshold_m_s": -0.01}, "thresholds"),
    ({"derivative_tau_s": 0.0}, "time constants"), ({"release_tau_s": -1.0}, "time constants"),
    ({"max_input_age_s": 0.0}, "input age"), ({"wheel_radius_m": -0.1}, "wheel radius")])
def test_gains_and_limits_out_of_range_are_config_errors_saying_which(kwargs, named):
    """Non-finite, negative or zero settings where the controller would silently do nothing
    (output_fraction 0: |PID_out| <= 0) or misbehave are refused, the message naming them."""
    with pytest.raises(ConfigError, match=named):
        TractionControlConfig(**kwargs)


def test_the_boundary_settings_that_are_allowed_are_accepted():
    """The closed ends of the documented ranges: gains and thresholds 0, output_fraction 1."""
    cfg = TractionControlConfig(kp=0.0, ki=0.0, kd=0.0, output_fraction=1.0,
                                wheel_speed_threshold_m_s=0.0, chassis_speed_threshold_m_s=0.0,
                                power_threshold_m2_s3=0.0)
    assert (cfg.kp, cfg.output_fraction, cfg.power_threshold_m2_s3) == (0.0, 1.0, 0.0)


@pytest.mark.parametrize("field, value", [
    ("wheel_speed_threshold_m_s", -0.01), ("chassis_speed_threshold_m_s", -0.5),
    ("power_threshold_m2_s3", -0.02), ("derivative_tau_s", 0.0), ("release_tau_s", -1.0),
    ("max_input_age_s", 0.0), ("wheel_radius_m", -0.1), ("omega_max_rad_s", 0.0)])
def test_a_setting_out_of_range_is_named_with_its_value(field, value):
    """The range errors said only "thresholds must be >= 0" or "wheel radius, speed limit,
    time constants and input age limit must be > 0", not which of the eight settings was
    wrong nor its value; they now name both (the project's rule for typed errors)."""
    with pytest.raises(ConfigError, match=rf"{field}={value}"):
        TractionControlConfig(**{field: value})
