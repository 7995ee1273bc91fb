"""Feed-forward slip limit: the terrain's largest acceleration at the target, the wheel limit,
and its effect on a start on ice (issue 11, estimator latency)."""

from __future__ import annotations

import numpy as np
import pytest

from terrain.control.closed_loop import run_closed_loop
from terrain.control.desired_slip import desired_slip
from terrain.control.feedforward import feedforward_step, traction_acceleration_limit
from terrain.terramechanics import get_terrain, steady_slip
from terrain.terramechanics.resistance import G_M_S2


def test_acceleration_limit_from_the_curve():
    ice = get_terrain("ICE")
    s_t = desired_slip(ice).traction                 # 95 % of the (saturated) ice friction
    assert traction_acceleration_limit(ice, s_t) == pytest.approx(G_M_S2 * 0.95 * 0.05,
                                                                   rel=1e-6)
    snow = get_terrain("SNOW")                       # at the steady slip mu = soil resistance
    assert traction_acceleration_limit(snow, steady_slip(snow)) == pytest.approx(0.0, abs=1e-6)
    assert traction_acceleration_limit(snow, 0.05) < 0.0          # cannot accelerate there


def test_feedforward_limits_the_wheel_to_the_reachable_ground_speed():
    r, s_t, a_max, dt = 0.2, 0.1, 0.5, 0.02
    v_ref = np.zeros(2)
    for _ in range(10):                              # 0.2 s with the command well above
        ff = feedforward_step(v_ref, np.zeros(2), np.array([5.0, -5.0]), a_max, s_t, r, dt)
        v_ref = ff.v_ref_m_s
    np.testing.assert_allclose(v_ref, 0.1)           # grown at a_max
    np.testing.assert_allclose(ff.omega_limit_rad_s, 0.1 / (r * 0.9))
    np.testing.assert_allclose(ff.correction_rad_s, [0.1 / 0.18 - 5.0, 5.0 - 0.1 / 0.18])
    # a faster estimate loosens the limit; a command below the limit is left alone
    ff = feedforward_step(v_ref, np.array([0.9, 0.9]), np.array([6.0, 1.0]), a_max, s_t, r, dt)
    np.testing.assert_allclose(ff.v_ref_m_s, [0.9, 0.9])
    np.testing.assert_allclose(ff.correction_rad_s, [0.9 / 0.18 - 6.0, 0.0], atol=1e-12)
    # never above the commanded rim speed, no growth with a negative acceleration limit
    ff = feedforward_step(np.array([0.3]), np.array([0.0]), np.array([1.0]), -1.0, s_t, r, dt)
    np.testing.assert_allclose(ff.v_ref_m_s, [0.2])


def test_feedforward_cuts_the_start_up_slip_on_ice():
    """The feedback alone sees the start-up slip late (estimator lag); the feed-forward
    limit does not need to see it."""
    kw = dict(duration_s=5.0)
    off = run_closed_loop("agrimaro", "ICE", "straight_accel", False, 3, **kw)[2]
    pid = run_closed_loop("agrimaro", "ICE", "straight_accel", True, 3, feed_forward=False,
                          **kw)[2]
    ff = run_closed_loop("agrimaro", "ICE", "straight_accel", True, 3, **kw)[2]
    assert pid["peak_slip"] > 0.85 * off["peak_slip"]
    assert ff["peak_slip"] < 0.6 * off["peak_slip"]
    assert ff["time_to_speed_s"] < 1.15 * off["time_to_speed_s"]
    assert ff["feed_forward"] and not pid["feed_forward"]
