"""Third review pass of the closed loop's controller callback
(terrain.control.closed_loop.TractionLoop): what a terrain decision callable may return."""

from __future__ import annotations

import numpy as np
import pytest
from control_helpers import observation

from terrain.control import build_slip_table, config_for_vehicle
from terrain.control.closed_loop import TractionLoop
from terrain.control.estimators import VelocityEstimate
from terrain.errors import ConfigError


class _ConstantEstimate:
    """Constant estimate: every wheel at ``rim_m_s`` (m/s at the rim) over the ground speed
    ``ground_m_s`` (m/s, also the chassis speed), accelerating at 1 m/s^2 (traction)."""

    name, limits = "fixed", "constant stub"

    def __init__(self, radius, rim_m_s=1.1, ground_m_s=1.0):
        self.radius, self.rim_m_s, self.ground_m_s = radius, rim_m_s, ground_m_s

    def update(self, obs):
        n = len(obs.omega_low_level)
        return VelocityEstimate(np.full(n, self.rim_m_s / self.radius),
                                np.full(n, self.ground_m_s), np.ones(n), self.ground_m_s, 0.0)


def _loop(decision):
    cfg, n = config_for_vehicle("husky", kp=2.0)
    loop = TractionLoop(cfg, n, _ConstantEstimate(cfg.wheel_radius_m),
                        build_slip_table(["GRASS", "ICE"]), decision, feed_forward=False)
    return loop, np.full(n, 1.1 / cfg.wheel_radius_m)


@pytest.mark.parametrize("decision", [("GRASS",), "GRASS", None, 0.9,
                                      ("GRASS", 0.9, 0.0, "extra"),
                                      ("GRASS", 0.9, "yesterday"), ("GRASS", 0.9, True)])
def test_a_malformed_terrain_decision_is_a_typed_error(decision):
    """The callable must return ``(label or None, confidence)`` or ``(label, confidence,
    t_decided_s)``. Before: a 1-tuple was Python's bare IndexError, None or a number a bare
    TypeError, the bare label "GRASS" was read as label "G" with confidence "R", a text time
    a bare ValueError, a fourth element was dropped unsaid and a boolean time True a decision
    made at 1 s."""
    loop, omega = _loop(lambda t: decision)
    with pytest.raises(ConfigError, match="terrain_decision"):
        loop(observation(0.02, omega))


@pytest.mark.parametrize("decision, fallback", [
    (("GRASS", 0.9), False), (["GRASS", 0.9, 0.01], False), (("GRASS", 0.9, None), True),
    ((None, 0.0), True), (("GRASS", 0.9, np.float64(-5.0)), True)])
def test_well_formed_decisions_still_pick_the_table_row(decision, fallback):
    """Pairs, triples (lists too) and a time of None (unknown: the fallback) as before."""
    loop, omega = _loop(lambda t: decision)
    loop(observation(0.02, omega))
    assert loop.log[-1]["fallback"] is fallback
    assert loop.log[-1]["target_traction"] == pytest.approx(0.0098, abs=1e-4) if fallback \
        else loop.log[-1]["target_traction"] == pytest.approx(0.3)


def test_a_call_whose_time_goes_back_gives_the_safe_output():
    """A call stamped before the previous one (a clock stepped back) has no interval to
    integrate over: the traction step's rule for a negative ``dt_s`` is the safe output,
    which clears the wheel's memory. Before, the loop floored the interval to 1 us like a
    repeated time and ran a normal step (ICE, slip 0.09 against 0.0098, ki 50: the integral
    of -0.162 rad/s was kept and -0.325 rad/s applied), and the acceleration filter moved
    away from the estimate with a negative weight (0.5 -> 0.483 towards 1)."""
    cfg, n = config_for_vehicle("husky", kp=2.0, ki=50.0)
    r = cfg.wheel_radius_m

    # ground 0.5 m/s, wheels 0.55 m/s rim (below omega_max)
    loop = TractionLoop(cfg, n, _ConstantEstimate(r, 0.55, 0.5), build_slip_table(["ICE"]),
                        lambda t: ("ICE", 1.0), feed_forward=False, accel_tau_s=0.3)
    omega = np.full(n, 0.55 / r)
    for t in (0.02, 0.04, 0.06):
        loop(observation(t, omega))
    assert not loop.log[-1]["safe"].any()
    assert np.all(loop.controller.state.integral < -0.1)
    a_before = np.full(n, 0.5)          # a filter still settling towards the estimate's 1
    loop.a_filtered = a_before.copy()
    c = loop(observation(0.05, omega))
    assert loop.log[-1]["safe"].all() and np.all(c == 0.0)
    np.testing.assert_array_equal(loop.a_filtered, a_before)
    assert np.all(loop.controller.state.integral == 0.0)
    # the next call in order runs normally again, from a cleared memory
    c = loop(observation(0.07, omega))
    assert not loop.log[-1]["safe"].any() and np.all(c < 0.0)
