"""Fifth review pass of the traction controller (terrain.control.traction): the one-sided
limiter where the low-level command and the wheel's ground velocity have opposite signs."""

from __future__ import annotations

import numpy as np
import pytest

from terrain.control.traction import (BRAKING, SlipTargets, TractionControlConfig,
                                      TractionState, traction_control_step)

TARGETS = SlipTargets(traction=0.1, braking=-0.15, steady=0.0)


def _one(cfg, omega_ll, omega_r, v_long, a_local, state=None, dt=0.02):
    """One wheel, r 1 m (omega r in m/s = omega in rad/s)."""
    state = TractionState.zeros(1) if state is None else state
    return traction_control_step(cfg, state, TARGETS, np.array([omega_ll]),
                                 np.array([omega_r]), np.array([v_long]),
                                 np.array([a_local]), abs(v_long), dt)


@pytest.mark.parametrize("sign", [1.0, -1.0])
def test_braking_against_the_command_never_speeds_the_wheel_beyond_it(sign):
    """Braking (Power_state = a v < 0) while the wheel centre moves against the command: the
    robot rolls back at 0.5 m/s, decelerating, the wheel is dragged back at 0.475 m/s (slip
    +0.05, eq. 8.4) under a forward command of 0.3 rad/s. The braking target is +0.15
    (sgn(v_long) (-0.15), eq. 8.8), so the error is +0.10. The one-sided limiter only moves
    a wheel towards the ground speed, which lies on the other side of 0: it may lower the
    command, never raise it. Before, the braking branch allowed only a positive correction
    (it looked at the command's sign alone): the command went 0.3 -> 0.4 rad/s, faster than
    commanded and away from the ground speed, regulating the slip up to the target (the
    two-sided regulation). Mirrored for a reversing command."""
    cfg = TractionControlConfig(kp=1.0)
    out, _ = _one(cfg, sign * 0.3, -sign * 0.475, -sign * 0.5, sign * 1.0)
    assert out.mode[0] == BRAKING
    assert out.slip[0] == pytest.approx(sign * 0.05)
    assert out.error[0] == pytest.approx(sign * 0.10)
    assert out.correction_rad_s[0] == 0.0
    assert out.omega_cmd_rad_s[0] == sign * 0.3


@pytest.mark.parametrize("sign", [1.0, -1.0])
def test_braking_slip_beyond_the_limit_against_the_command_is_cut(sign):
    """Same robot rolling back at 0.5 m/s, the wheel held back to 0.3 m/s by a forward
    command of 0.3 rad/s: slip +0.40 (eq. 8.4), beyond the braking limit +0.15 by 0.25.
    Lowering the command (towards the ground speed) reduces it: kp 1 gives -0.25 rad/s.
    Before, the limiter allowed only a positive correction there, so this excess braking slip
    was never cut (correction 0). Mirrored for a reversing command."""
    cfg = TractionControlConfig(kp=1.0)
    out, _ = _one(cfg, sign * 0.3, -sign * 0.3, -sign * 0.5, sign * 1.0)
    assert out.mode[0] == BRAKING
    assert out.slip[0] == pytest.approx(sign * 0.40)
    assert out.error[0] == pytest.approx(-sign * 0.25)
    assert out.correction_rad_s[0] == pytest.approx(-sign * 0.25)


def test_one_sided_command_magnitude_never_exceeds_the_low_level_one_against_the_ground():
    """Where the command and the wheel's ground velocity have opposite signs, the one-sided
    limiter's command stays within [0, omega_low_level] in every mode (traction, braking,
    steady), whatever the measured wheel speed and the PID memory: 400 random steps."""
    cfg = TractionControlConfig(kp=2.0, ki=20.0, kd=0.05, omega_max_rad_s=5.0)
    rng = np.random.default_rng(11)
    state = TractionState.zeros(4)
    for _ in range(400):
        ll = rng.uniform(0.1, 2.0, 4) * np.array([1, 1, -1, -1])
        v = -np.sign(ll) * rng.uniform(0.1, 2.0, 4)
        wr = rng.uniform(-2.5, 2.5, 4)
        a = rng.uniform(-3.0, 3.0, 4)
        out, state = traction_control_step(cfg, state, TARGETS, ll, wr, v, a, 1.0, 0.02)
        cmd = out.omega_cmd_rad_s
        assert np.all(np.abs(cmd) <= np.abs(ll) + 1e-12)
        assert np.all(cmd * ll >= 0.0)
