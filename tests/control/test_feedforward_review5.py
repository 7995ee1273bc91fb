"""Fifth review pass of the feed-forward slip limit (terrain.control.feedforward): booleans
taken as numbers."""

from __future__ import annotations

import numpy as np
import pytest

from terrain.control.feedforward import feedforward_step
from terrain.errors import ConfigError, DataFormatError


def _args(**kw):
    """Two wheels at 5 rad/s from rest, a_max 1 m/s^2, target 0.1, r 0.2 m, dt 0.02 s."""
    args = {"v_ref_m_s": np.zeros(2), "v_est_m_s": np.zeros(2),
            "omega_low_level_rad_s": np.array([5.0, 5.0]), "accel_limit_m_s2": 1.0,
            "target_slip": 0.1, "wheel_radius_m": 0.2, "dt_s": 0.02}
    args.update(kw)
    return args


def test_numeric_settings_give_the_ramp():
    """The reference grows by a_max dt = 0.02 m/s; the limit is 0.02 / (0.2 0.9) rad/s."""
    ff = feedforward_step(**_args())
    np.testing.assert_allclose(ff.v_ref_m_s, [0.02, 0.02])
    np.testing.assert_allclose(ff.omega_limit_rad_s, [0.02 / 0.18] * 2)


@pytest.mark.parametrize("name, value", [
    ("dt_s", True), ("dt_s", np.True_), ("wheel_radius_m", True),
    ("accel_limit_m_s2", np.True_), ("target_slip", False)])
def test_a_boolean_setting_is_a_config_error_naming_it(name, value):
    """float(True) is 1: dt_s=True ramped the reference by a whole second (1 m/s instead of
    0.02 m/s, the wheel's limit 50 times too high), wheel_radius_m=True took a 1 m wheel,
    target_slip=False a target of 0, all without a word."""
    with pytest.raises(ConfigError, match=f"feedforward_step.{name} must be a real number"):
        feedforward_step(**_args(**{name: value}))


@pytest.mark.parametrize("name", ["omega_low_level_rad_s", "v_est_m_s", "v_ref_m_s"])
def test_a_boolean_array_is_a_typed_error_naming_it(name):
    """A boolean command array was a command of 1 rad/s (limit engaged, correction -0.89)."""
    with pytest.raises(DataFormatError, match=f"{name} must hold real numbers"):
        feedforward_step(**_args(**{name: np.array([True, True])}))


@pytest.mark.parametrize("slip", [True, "0.1", None, float("nan"), float("inf"), 1.5, -2.0])
def test_the_acceleration_limit_refuses_a_slip_that_is_not_a_magnitude_in_0_1(slip):
    """slip is a slip magnitude in [0, 1] (its sign ignored). True was slip 1, the text
    '0.1' slip 0.1, 1.5 read the curve beyond full spin (ICE: 0.49 m/s^2) and NaN gave a
    NaN limit, all without a word."""
    from terrain.control.feedforward import traction_acceleration_limit
    from terrain.terramechanics import get_terrain

    with pytest.raises(ConfigError, match="slip"):
        traction_acceleration_limit(get_terrain("ICE"), slip)


def test_the_acceleration_limit_still_takes_either_end_of_the_range():
    """0 and +-1 are slips (at rest, full spin or a locked wheel); g (mu - rho) there."""
    from terrain.control.feedforward import traction_acceleration_limit
    from terrain.terramechanics import get_terrain

    ice = get_terrain("ICE")
    assert traction_acceleration_limit(ice, 0.0) == pytest.approx(0.0, abs=1e-12)
    assert traction_acceleration_limit(ice, -1.0) == traction_acceleration_limit(ice, 1.0)
