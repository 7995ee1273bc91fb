"""Review tests (ctl12) of the traction controller (terrain.control.traction): the per-wheel
enable compares the wheel's *rim* speed (m/s) with its threshold, and the integral is held
within this step's room before it integrates."""

from __future__ import annotations

import numpy as np
import pytest

from terrain.control.traction import (SlipTargets, TractionControlConfig, TractionState,
                                      traction_control_step)

TARGETS = SlipTargets(traction=0.1, braking=-0.15, steady=0.05)


def _step(radius, omega, v, slip, state=None, **cfg):
    config = TractionControlConfig(kp=1.0, wheel_radius_m=radius, **cfg)
    o = np.array([omega])
    return traction_control_step(config, state or TractionState.zeros(1), TARGETS, o, o,
                                 np.array([v]), np.zeros(1), 0.1, 0.02,
                                 slip=np.array([slip]))


@pytest.mark.parametrize("radius, omega, v, acts", [
    (0.1, 0.4, 0.03, False),    # 0.4 rad/s, but a rim of 0.04 m/s: below 0.05 m/s
    (2.0, 0.03, 0.01, True),    # 0.03 rad/s, but a rim of 0.06 m/s: above it
])
def test_the_wheel_speed_threshold_is_on_the_rim_speed_in_m_s(radius, omega, v, acts):
    """max(|omega r|, |v_long|) >= 0.05 m/s (ch. 8.3.2). Every other test has r = 1 m,
    so a mutant comparing omega in rad/s with the threshold survived them; it would enable
    a 0.165 m AgriMaRo wheel's error at 0.05 rad/s (8 mm/s at the rim)."""
    out, state = _step(radius, omega, v, slip=0.5)
    assert bool(state.slip_valid[0]) is acts
    if acts:   # e = 0.1 - 0.5, limited to the half-line: the command goes to 0, not below
        assert out.error[0] == pytest.approx(-0.4)
        assert out.omega_cmd_rad_s[0] == pytest.approx(0.0)
    else:
        assert out.error[0] == 0.0 and out.correction_rad_s[0] == 0.0


def test_an_integral_beyond_this_steps_room_is_dropped_before_integrating():
    """The room moved (a traction limiter, hi = 0, after a state whose integral is +3 rad/s):
    the integral is clamped to [lo, max(hi, 0)] = [.., 0] before integrating, so a small
    negative error acts at once; without that clamp the +3 would absorb it for 3 / (ki e dt)
    steps (kp 0, ki 10, e -0.1: 0 output where -0.02 is due)."""
    held = TractionState.zeros(1)._replace(integral=np.array([3.0]),
                                           active=np.array([True]))
    config = TractionControlConfig(kp=0.0, ki=10.0)
    o = np.array([1.0])
    out, state = traction_control_step(config, held, TARGETS, o, o, np.array([0.9]),
                                       np.zeros(1), 0.9, 0.02, slip=np.array([0.2]))
    # e = 0.1 - 0.2 = -0.1; integral 0 + ki e dt = -0.02
    assert out.correction_rad_s[0] == pytest.approx(-0.02)
    assert state.integral[0] == pytest.approx(-0.02)
