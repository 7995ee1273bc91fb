"""Third review pass of the traction controller (terrain.control.traction): inputs that were
taken silently, and behaviour of the PID that no test pinned down."""

from __future__ import annotations

import numpy as np
import pytest

from terrain.control.traction import (SlipTargets, TractionControlConfig, TractionState,
                                      traction_control_step)
from terrain.errors import DataFormatError

TARGETS = SlipTargets(traction=0.1, braking=-0.15, steady=0.0)


def _args(**kw):
    """Table 8.1 case 1A (v_long 0.6 m/s, omega r 0.7 m/s, r 1 m) in traction."""
    args = {"omega_low_level_rad_s": np.array([0.7]), "omega_meas_rad_s": np.array([0.7]),
            "v_long_m_s": np.array([0.6]), "a_local_m_s2": np.array([1.0]),
            "chassis_speed_m_s": 0.6, "dt_s": 0.02, "input_age_s": 0.0}
    args.update(kw)
    return args


@pytest.mark.parametrize("name, value", [
    ("dt_s", True), ("dt_s", np.True_), ("chassis_speed_m_s", True),
    ("input_age_s", False), ("omega_low_level_rad_s", np.array([True])),
    ("omega_meas_rad_s", [True]), ("v_long_m_s", np.array([True])),
    ("a_local_m_s2", np.array([False])), ("slip", np.array([True]))])
def test_a_boolean_input_is_a_typed_error_naming_it(name, value):
    """A boolean is not a number of seconds, metres per second or radians per second.
    Before, float() took it: ``dt_s=True`` integrated the error over a whole second (ki 10,
    error -0.043: -0.43 rad/s in one step), ``chassis_speed_m_s=True`` enabled the correction
    at 1 m/s, ``input_age_s=False`` passed as a fresh estimate and a boolean command array
    was a command of 1 rad/s (case 1A gave 0.957 rad/s)."""
    cfg = TractionControlConfig(kp=1.0, ki=10.0)
    with pytest.raises(DataFormatError, match=f"{name} must hold real numbers.*bool"):
        traction_control_step(cfg, TractionState.zeros(1), TARGETS, **_args(**{name: value}))


def test_numeric_inputs_still_give_table_8_1_case_1a():
    """Plain and NumPy numbers (including integers) are taken as before: case 1A, kp 1,
    PID_out -0.0429, omega_ODrive 0.657 rad/s."""
    cfg = TractionControlConfig(kp=1.0)
    for kw in ({}, {"dt_s": np.float64(0.02), "chassis_speed_m_s": 1, "input_age_s": 0},
               {"omega_low_level_rad_s": [0.7], "a_local_m_s2": np.array([1])}):
        out, _ = traction_control_step(cfg, TractionState.zeros(1), TARGETS, **_args(**kw))
        assert out.omega_cmd_rad_s[0] == pytest.approx(0.7 + 0.1 - 0.1 / 0.7)   # 0.6571
        assert not out.safe[0]


@pytest.mark.parametrize("radius, resolution", [
    (0.165, "0.25"), (None, 0.25), (0.165, True), (True, 0.25), (0.165, np.inf),
    (np.inf, 0.25), (0.165, np.nan)])
def test_encoder_resolution_refuses_what_is_not_a_finite_positive_number(radius, resolution):
    """Before: text or None was Python's bare TypeError of ``'>' not supported``, True a
    radius or resolution of 1 (AgriMaRo: 2.33 m/s or 0.096 m/s instead of 0.384 m/s), an
    infinite resolution a threshold of 0 m/s (no dead band at all) and an infinite radius an
    infinite one (the controller never acts)."""
    from terrain.control.traction import encoder_resolution_speed_m_s
    from terrain.errors import ConfigError
    from terrain.vehicles import get_vehicle

    motor = get_vehicle("agrimaro").motor
    with pytest.raises(ConfigError, match="wheel_radius_m|slip_resolution"):
        encoder_resolution_speed_m_s(motor, radius, resolution)


def test_encoder_resolution_of_the_agrimaro_is_0_384_m_s():
    """r q / (tau s_res) = 0.165 (2 pi / 90) / (0.12 0.25) = 0.384 m/s (its docstring);
    numeric inputs of NumPy types are taken as before."""
    from terrain.control.traction import encoder_resolution_speed_m_s
    from terrain.vehicles import get_vehicle

    motor = get_vehicle("agrimaro").motor
    expected = 0.165 * (2 * np.pi / 90) / (0.12 * 0.25)
    assert encoder_resolution_speed_m_s(motor, 0.165) == pytest.approx(expected)
    assert encoder_resolution_speed_m_s(motor, np.float64(0.165), 1) == pytest.approx(
        expected * 0.25)
