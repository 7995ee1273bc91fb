"""Review tests (ctl12) of the closed loop's controller callback
(terrain.control.closed_loop.TractionLoop): a call stamped at an infinite time."""

from __future__ import annotations

import numpy as np
import pytest
from control_helpers import observation
from test_closed_loop_review3 import _ConstantEstimate

from terrain.control import build_slip_table, config_for_vehicle
from terrain.control.closed_loop import TractionLoop


@pytest.mark.parametrize("feed_forward", [False, True])
@pytest.mark.parametrize("bad_t", [np.inf, -np.inf])
def test_a_call_at_an_infinite_time_gives_the_safe_output(feed_forward, bad_t):
    """The docstring promises the safe output at a call whose time is not finite; NaN got
    it, but +inf gave an interval of +inf that the feed-forward ramp took as elapsed time
    (feedforward_step's ConfigError "a finite dt_s" stopped the run) and the acceleration
    filter jumped to the new sample. Now +-inf is handled as NaN is: this call and the
    next (whose interval from +-inf is not finite or goes back) are safe, the ramp and the
    filter do not move, then normal steps."""
    cfg, n = config_for_vehicle("husky", kp=2.0)
    r = cfg.wheel_radius_m
    loop = TractionLoop(cfg, n, _ConstantEstimate(r, 0.6, 0.2), build_slip_table(["ICE"]),
                        lambda t: ("ICE", 1.0), feed_forward=feed_forward)
    omega = np.full(n, 0.6 / r)
    for t in (0.02, 0.04):
        loop(observation(t, omega))
    v_ref, a = loop.v_ref.copy(), loop.a_filtered.copy()
    for t in (bad_t, 0.06):
        c = loop(observation(t, omega))
        assert loop.log[-1]["safe"].all() and np.all(c == 0.0)
        np.testing.assert_array_equal(loop.a_filtered, a)
        np.testing.assert_array_equal(loop.v_ref, v_ref if not feed_forward
                                      else np.maximum(v_ref, 0.2))
    c = loop(observation(0.08, omega))
    assert not loop.log[-1]["safe"].any() and np.all(c < 0.0)
