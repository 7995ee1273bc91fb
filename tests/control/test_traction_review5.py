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
