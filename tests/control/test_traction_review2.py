"""Second review pass of the traction controller (terrain.control.traction) and the
feed-forward limit (terrain.control.feedforward): behaviour the first tests left open."""

from __future__ import annotations

import numpy as np
import pytest

from terrain.control.feedforward import feedforward_step
from terrain.control.traction import (TRACTION, SlipTargets, TractionControlConfig,
                                      TractionState, traction_control_step)
from terrain.errors import ConfigError

TARGETS = SlipTargets(traction=0.1, braking=-0.15, steady=0.0)


def _step(cfg, state, omega_ll, omega, v, a, chassis=0.5, dt=0.01, **kw):
    arr = (lambda x: np.atleast_1d(np.asarray(x, dtype=float)))  # noqa: E731
    return traction_control_step(cfg, state, TARGETS, arr(omega_ll), arr(omega), arr(v),
                                 arr(a), chassis, dt, **kw)


@pytest.mark.parametrize("threshold", [0.01, 0.0])
def test_the_slip_dead_band_is_the_configured_wheel_speed_threshold(threshold):
    """The slip's dead band (ch. 7.2.1) is the controller's wheel speed threshold, not the
    thesis's 0.05 m/s: with the threshold at 0.01 m/s (or 0) a wheel turning at 0.04 m/s over
    a ground speed of 0.02 m/s is regulated, so its slip must be measured, (0.04 - 0.02) /
    0.04 = 0.5 (eqs. 8.4-8.5), error 0.1 - 0.5 = -0.4 (kp 1: -0.4 rad/s). A fixed 0.05 m/s
    dead band reads slip 0 there and the controller pushes the spinning wheel *up* by 0.1."""
    cfg = TractionControlConfig(kp=1.0, one_sided=False, wheel_speed_threshold_m_s=threshold)
    out, _ = _step(cfg, TractionState.zeros(1), 5.0, 0.04, 0.02, 10.0)   # r 1 m; a v = 0.2
    assert out.mode[0] == TRACTION
    assert out.slip[0] == pytest.approx(0.5)
    assert out.error[0] == pytest.approx(-0.4)
    assert out.correction_rad_s[0] == pytest.approx(-0.4)


def test_a_wheel_inside_a_wider_dead_band_reports_slip_zero():
    """AgriMaRo-like threshold 0.384 m/s (encoder resolution): a wheel at 0.2 m/s over
    0.15 m/s is inside the dead band, so its slip is 0 and nothing is corrected."""
    cfg = TractionControlConfig(kp=1.0, one_sided=False, wheel_speed_threshold_m_s=0.384)
    out, state = _step(cfg, TractionState.zeros(1), 5.0, 0.2, 0.15, 10.0)
    assert out.slip[0] == 0.0 and out.error[0] == 0.0 and out.correction_rad_s[0] == 0.0
    assert not state.slip_valid[0]


@pytest.mark.parametrize("bad", [{"dt": 0.0}, {"v": np.nan}, {"input_age_s": 1.0}])
def test_the_safe_output_forgets_the_derivative_too(bad):
    """A safe-output step (a repeated time stamp, a NaN estimate, a stale one) resets the
    wheel's whole memory (module docstring: "resets that wheel's state"), the derivative
    filter included: the next step starts with derivative 0 (no previous slip to
    differentiate), so it gives kp e only. Kept, the slip before the dropout (0.2) against
    the one after (0.0) over 10 ms would kick the output by kd 20 1/s = +1 rad/s at once."""
    cfg = TractionControlConfig(kp=1.0, kd=0.05, derivative_tau_s=1e-9, one_sided=False)
    state = TractionState.zeros(1)
    for slip in (0.1, 0.2):                                   # slip rising: derivative 10 1/s
        out, state = _step(cfg, state, 5.0, 0.6 / (1.0 - slip), 0.6, 1.0)
    assert state.derivative[0] == pytest.approx(10.0) and state.slip_valid[0]
    kw = {"dt": bad.get("dt", 0.01), "input_age_s": bad.get("input_age_s", 0.0)}
    out, state = _step(cfg, state, 5.0, 0.6 / 0.8, bad.get("v", 0.6), 1.0, **kw)
    assert out.safe[0]
    assert (state.integral[0], state.derivative[0], state.correction[0]) == (0.0, 0.0, 0.0)
    assert not state.slip_valid[0] and not state.active[0]
    out, state = _step(cfg, state, 5.0, 0.6, 0.6, 1.0)       # slip 0 again, error 0.1
    assert state.derivative[0] == 0.0
    assert out.correction_rad_s[0] == pytest.approx(0.1)


def test_feedforward_uses_the_magnitude_of_a_signed_target():
    """feedforward_step takes the traction target as a magnitude (``|target_slip|``): a
    target handed with its sign for reversing (-0.2) gives the same limit as +0.2,
    v_ref / (r (1 - 0.2)), not the lower v_ref / (r 1.2); and |-1| is refused like 1."""
    args = (np.array([0.1, 0.1]), np.zeros(2), np.array([5.0, -5.0]), 0.5)
    pos = feedforward_step(*args, 0.2, 0.2, 0.02)
    neg = feedforward_step(*args, -0.2, 0.2, 0.02)
    np.testing.assert_allclose(pos.omega_limit_rad_s, 0.11 / (0.2 * 0.8))
    for a, b in zip(pos, neg):
        np.testing.assert_array_equal(a, b)
    with pytest.raises(ConfigError, match="target_slip"):
        feedforward_step(*args, -1.0, 0.2, 0.02)


def test_while_the_wheel_speed_limit_pins_the_output_the_integral_grows_up_to_it():
    """Conditional integration against the room the output has at that step, also where a
    low-level command beyond omega_max + the output limit pins the correction: omega_max 20,
    limit 5, command 26 rad/s: the room is the single value -6 (command 20). A wheel
    slipping 0.2 against the target 0.1 (kp 45: p = -4.5, ki e dt = -0.01) keeps the
    integral growing until p + I reaches that -6, I = -1.5, not stopping at the output
    limit's -5 (I = -0.5). When the command drops to 15 rad/s and the slip to the target,
    the correction is that integral, -1.5 rad/s."""
    cfg = TractionControlConfig(kp=45.0, ki=10.0, omega_max_rad_s=20.0, output_fraction=0.25)
    state = TractionState.zeros(1)
    for _ in range(300):
        out, state = _step(cfg, state, 26.0, 25.0, 20.0, 1.0, chassis=20.0)
    assert out.mode[0] == TRACTION and out.error[0] == pytest.approx(-0.1)
    assert out.omega_cmd_rad_s[0] == pytest.approx(20.0)
    assert state.integral[0] == pytest.approx(-1.5, abs=1e-9)
    out, state = _step(cfg, state, 15.0, 20.0 / 0.9, 20.0, 1.0, chassis=20.0)
    assert out.error[0] == pytest.approx(0.0, abs=1e-12)
    assert out.correction_rad_s[0] == pytest.approx(-1.5, abs=1e-9)
