"""Fifth review pass of the traction controller (terrain.control.traction)."""

from __future__ import annotations

import numpy as np
import pytest

from terrain.control.traction import (SlipTargets, TractionControlConfig, TractionState,
                                      traction_control_step)
from terrain.errors import ShapeError

TARGETS = SlipTargets(traction=0.1, braking=-0.15, steady=0.0)


def _three_wheels(state):
    """Table 8.1 case 1A on three wheels (r 1 m, kp 1)."""
    o = np.full(3, 0.7)
    return traction_control_step(TractionControlConfig(kp=1.0), state, TARGETS, o, o,
                                 np.full(3, 0.6), np.ones(3), 0.6, 0.02)


@pytest.mark.parametrize("field", ["slip_prev", "slip_valid", "derivative", "correction",
                                   "active"])
def test_a_state_whose_fields_disagree_in_length_is_a_shape_error_naming_the_field(field):
    """Only the integral's shape was checked: a state (restored from a log, built by hand)
    with slip_prev of two entries under three wheels silently dropped the third wheel, zip
    stopping at the shortest (three commands in, two out: [0.657, 0.657])."""
    bad = TractionState.zeros(3)._replace(**{field: np.zeros(2, dtype=float)})
    with pytest.raises(ShapeError, match=f"{field} \\(2,\\)"):
        _three_wheels(bad)


def test_a_consistent_state_still_gives_every_wheel_its_command():
    out, state = _three_wheels(TractionState.zeros(3))
    np.testing.assert_allclose(out.omega_cmd_rad_s, [0.7 - (0.7 - 0.6) / 0.7 + 0.1] * 3)
    assert all(np.shape(a) == (3,) for a in state)


@pytest.mark.parametrize("chassis", [-0.6, -1e-9])
def test_a_negative_chassis_speed_is_refused_naming_it(chassis):
    """chassis_speed_m_s is the magnitude of the chassis velocity (ch. 8.3.2). A signed
    speed (a robot reversing at 0.6 m/s passed as -0.6) was taken as below the enabling
    threshold: the correction never reached the motors while reversing, without a word."""
    from terrain.errors import ImplausibleValueError

    o = np.full(1, -0.7)
    with pytest.raises(ImplausibleValueError, match="chassis_speed_m_s.*magnitude"):
        traction_control_step(TractionControlConfig(kp=1.0), TractionState.zeros(1),
                              TARGETS, o, o, np.full(1, -0.6), -np.ones(1), chassis, 0.02)


def test_a_chassis_at_rest_or_of_unknown_speed_is_still_taken():
    """0 is a magnitude (controller disabled); NaN still gives the safe output."""
    o = np.full(1, 0.7)
    args = (TractionControlConfig(kp=1.0), TractionState.zeros(1), TARGETS, o, o,
            np.full(1, 0.6), np.ones(1))
    out, _ = traction_control_step(*args, 0.0, 0.02)
    assert not out.enabled[0] and not out.safe[0]
    out, _ = traction_control_step(*args, float("nan"), 0.02)
    assert out.safe[0]
