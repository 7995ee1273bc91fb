"""Review checks (ctl19) of the control layer: the targets a traction step reads from any
record with the three attributes, the feed-forward limit's inputs, and the confidence rule
of the desired-slip table."""

from __future__ import annotations

import types

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from terrain.control.traction import (SlipTargets, TractionControlConfig, TractionState,
                                      traction_control_step)
from terrain.errors import ConfigError

FAST = settings(max_examples=60, deadline=None)


def _step(targets, slip=0.1):
    """One two-sided step of one wheel driving forward (1 rad/s, r 1 m) while accelerating."""
    cfg = TractionControlConfig(one_sided=False)
    return traction_control_step(cfg, TractionState.zeros(1), targets, [1.0], [1.0], [0.9],
                                 [0.5], 1.0, 0.02, 0.0, [slip])[0]


# --- targets read from any record ---------------------------------------------------------

@pytest.mark.parametrize("traction, braking, steady, named", [
    (-0.1, -0.15, 0.0, "traction"),    # wrong sign: the limiter slows a wheel that grips
    (0.1, 0.15, 0.0, "braking"),
    (0.1, -0.15, -0.05, "steady"),
    (1.5, -0.15, 0.0, "traction"),     # beyond the SAE slip's range
    ("0.1", -0.15, 0.0, "traction"),   # text: Python's bare TypeError in math.isfinite
    (True, -0.15, 0.0, "traction"),    # a boolean: read as a target of 1
    (0.1, -0.15, np.True_, "steady"),
    (None, -0.15, 0.0, "traction"),
])
def test_targets_of_a_plain_record_are_checked_as_slip_targets_are(traction, braking, steady,
                                                                   named):
    """A record with the three attributes (not a :class:`SlipTargets`, whose construction
    checks them) was read unchecked: a traction target of -0.1 made the step slow a wheel
    driving at a slip of 0.1 by 0.2 rad/s (error -0.2), ``True`` was a target of 1, text
    stopped on a bare TypeError. Now the :class:`SlipTargets` rule, named."""
    record = types.SimpleNamespace(traction=traction, braking=braking, steady=steady)
    with pytest.raises(ConfigError, match=rf"targets\.{named} must"):
        _step(record)


@FAST
@given(st.floats(0.01, 1.0), st.floats(-1.0, -0.01), st.floats(0.0, 1.0),
       st.floats(-1.0, 1.0))
def test_a_valid_plain_record_steps_as_the_same_slip_targets(traction, braking, steady, slip):
    """Valid targets in any record give the step of the same :class:`SlipTargets`."""
    record = types.SimpleNamespace(traction=traction, braking=braking, steady=steady)
    got, want = _step(record, slip), _step(SlipTargets(traction, braking, steady), slip)
    for a, b in zip(got, want):
        np.testing.assert_array_equal(a, b)


@pytest.mark.parametrize("bad", [np.nan, np.inf, -np.inf])
def test_a_non_finite_target_of_a_plain_record_still_gives_the_safe_output(bad):
    """Unchanged: a non-finite target is not known, so the step adds nothing."""
    for field in ("traction", "braking", "steady"):
        values = {"traction": 0.1, "braking": -0.15, "steady": 0.0, field: bad}
        out = _step(types.SimpleNamespace(**values))
        assert out.safe.all() and out.correction_rad_s[0] == 0.0
