"""Fifth review pass of the closed loop (terrain.control.closed_loop.TractionLoop)."""

from __future__ import annotations

import numpy as np
import pytest
from control_helpers import observation
from test_closed_loop_review3 import _ConstantEstimate

from terrain.control import build_slip_table, config_for_vehicle
from terrain.control.closed_loop import TractionLoop
from terrain.errors import ConfigError


def _spinning(radius):
    """Constant estimate: ground 0.2 m/s, wheels at 0.6 m/s rim (slip 0.67), accelerating."""
    return _ConstantEstimate(radius, 0.6, 0.2)


def test_a_call_whose_time_goes_back_does_not_move_the_feed_forward_ramp():
    """With the feed-forward on, a call stamped before the previous one has no interval:
    the ramp of the reference ground speed grows by a_max x 0 (it is still lifted to the
    estimate, 0.2 m/s), the correction is the safe output's 0, and the next call in order
    ramps from there. A negative interval handed to feedforward_step is a ConfigError that
    stopped the run."""
    cfg, n = config_for_vehicle("husky", kp=2.0)
    r = cfg.wheel_radius_m
    loop = TractionLoop(cfg, n, _spinning(r), build_slip_table(["ICE"]),
                        lambda t: ("ICE", 1.0), feed_forward=True)
    omega = np.full(n, 0.6 / r)
    for t in (0.02, 0.04, 0.06):
        loop(observation(t, omega))
    assert loop.ff_engaged.all()
    v_ref = loop.v_ref.copy()
    c = loop(observation(0.05, omega))
    assert loop.log[-1]["safe"].all() and np.all(c == 0.0)
    np.testing.assert_array_equal(loop.v_ref, np.maximum(v_ref, 0.2))
    c = loop(observation(0.07, omega))
    assert not loop.log[-1]["safe"].any() and np.all(c < 0.0)
    assert np.all(loop.v_ref > v_ref)


@pytest.mark.parametrize("name, value", [("apply", "no"), ("apply", 0), ("apply", None),
                                         ("feed_forward", "off"), ("feed_forward", 1)])
def test_a_switch_that_is_not_a_boolean_is_a_typed_error_naming_it(name, value):
    """apply and feed_forward were read by truthiness: apply='no' (the text of a config
    file) ran the controller on the robot instead of in shadow mode, feed_forward='off'
    switched the feed-forward on, and 0 / 1 passed as False / True; a NumPy boolean is
    still a boolean."""
    cfg, n = config_for_vehicle("husky", kp=2.0)
    args = (cfg, n, _spinning(cfg.wheel_radius_m), build_slip_table(["ICE"]),
            lambda t: ("ICE", 1.0))
    with pytest.raises(ConfigError, match=f"TractionLoop.{name} must be True or False"):
        TractionLoop(*args, **{name: value})
    loop = TractionLoop(*args, **{name: np.False_})
    assert getattr(loop, name) is False


@pytest.mark.parametrize("feed_forward", [False, True])
@pytest.mark.parametrize("bad_t", [np.nan, np.inf, -np.inf])
def test_a_call_at_a_non_finite_time_gives_the_safe_output_with_or_without_feed_forward(
        feed_forward, bad_t):
    """A NaN call time leaves the interval unknown: the traction step's safe output (its
    rule for a non-finite dt_s), on this call and the next (whose interval from a NaN is
    unknown too), then normal steps. With the feed-forward on, the NaN interval reached
    feedforward_step and stopped the run with a ConfigError about its dt_s; the ramp and
    the acceleration filter now move by a zero interval, as for a time that went back.
    +-inf is handled as NaN is (ctl12: +inf gave an interval of +inf that the ramp took as
    elapsed time, feedforward_step's "a finite dt_s" stopped the run, and the filter jumped
    to the new sample)."""
    cfg, n = config_for_vehicle("husky", kp=2.0)
    r = cfg.wheel_radius_m
    loop = TractionLoop(cfg, n, _spinning(r), build_slip_table(["ICE"]),
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
