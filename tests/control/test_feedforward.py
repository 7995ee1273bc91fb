"""Feed-forward slip limit: the terrain's largest acceleration at the target, the wheel limit,
and its effect on a start on ice (issue 11, estimator latency)."""

from __future__ import annotations

import re

import numpy as np
import pytest

from terrain.control.closed_loop import run_closed_loop
from terrain.control.desired_slip import desired_slip
from terrain.control.feedforward import feedforward_step, traction_acceleration_limit
from terrain.errors import ConfigError
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
    # reversing: v_long is signed, the reference a magnitude; a robot already backing at
    # 0.9 m/s lifts it as one driving forward does (limit 0.9 / 0.18 = 5 rad/s either way)
    ff = feedforward_step(np.zeros(2), np.array([-0.9, 0.9]), np.array([-6.0, 6.0]), a_max,
                          s_t, r, dt)
    np.testing.assert_allclose(ff.v_ref_m_s, [0.9, 0.9])
    np.testing.assert_allclose(ff.correction_rad_s, [1.0, -1.0])
    # never above the commanded rim speed, no growth with a negative acceleration limit
    ff = feedforward_step(np.array([0.3]), np.array([0.0]), np.array([1.0]), -1.0, s_t, r, dt)
    np.testing.assert_allclose(ff.v_ref_m_s, [0.2])
    # ... nor shrinking (the rim speed 1.0 m/s is above it: only the clamp of a_max at 0
    # keeps the reference at 0.3, a_max dt would take it to 0.28 and slow the wheel)
    ff = feedforward_step(np.array([0.3]), np.array([0.0]), np.array([5.0]), -1.0, s_t, r, dt)
    np.testing.assert_allclose(ff.v_ref_m_s, [0.3])
    np.testing.assert_allclose(ff.correction_rad_s, [0.3 / 0.18 - 5.0])


def test_engaged_limit_is_released_no_faster_than_the_terrain_accelerates():
    """An estimate that jumps ahead (the lagging slip estimate of a start-up) lifts the
    reference only by ``a_max dt`` once the limit binds; a free limit follows it at once."""
    r, s_t, a_max, dt = 0.2, 0.3, 0.5, 0.02
    omega = np.array([5.0, 5.0])
    ff = feedforward_step(np.array([0.2, 0.2]), np.zeros(2), omega, a_max, s_t, r, dt,
                          engaged=np.array([True, False]))
    assert ff.engaged.tolist() == [True, True]
    jump = feedforward_step(ff.v_ref_m_s, np.array([0.6, 0.6]), omega, a_max, s_t, r, dt,
                            engaged=np.array([True, False]))
    np.testing.assert_allclose(jump.v_ref_m_s, [0.2 + 2 * a_max * dt, 0.6])
    assert jump.correction_rad_s[0] < jump.correction_rad_s[1] < 0.0
    # an estimate below the grown reference changes nothing: the engaged limit still grows
    slow = feedforward_step(ff.v_ref_m_s, np.array([0.0, 0.0]), omega, a_max, s_t, r, dt,
                            engaged=ff.engaged)
    np.testing.assert_allclose(slow.v_ref_m_s, 0.2 + 2 * a_max * dt)


def test_a_command_exactly_at_its_limit_does_not_engage_it():
    """With a zero target slip the reference that has caught up with the rim speed puts the
    limit exactly at the command: nothing to correct, and the limit does not bind (the
    command is not above it), so the next step's estimate lifts the reference freely."""
    r, a_max, dt = 0.5, 0.5, 0.02
    ff = feedforward_step(np.array([1.0]), np.zeros(1), np.array([2.0]), a_max, 0.0, r, dt)
    np.testing.assert_allclose(ff.omega_limit_rad_s, [2.0])
    assert ff.engaged.tolist() == [False] and ff.correction_rad_s.tolist() == [0.0]
    nxt = feedforward_step(ff.v_ref_m_s, np.array([1.5]), np.array([4.0]), a_max, 0.0, r, dt,
                           engaged=ff.engaged)
    np.testing.assert_allclose(nxt.v_ref_m_s, [1.5])        # not held to 1.0 + a_max dt


@pytest.mark.slow
@pytest.mark.parametrize("vehicle,estimator,terrains", [
    ("husky", "fused", ("SNOW", "ICE", "GRASS", "TILES")),
    ("husky", "observer", ("SNOW", "ICE")),
    ("agrimaro", None, ("SNOW", "ICE", "SANDY_LOAM"))])
def test_control_never_raises_the_peak_slip(vehicle, estimator, terrains):
    """Invariant: with the controller on, the start-up peak slip is never above the
    uncontrolled run's (same seed). Before the engaged-limit release the Husky with the fused
    estimate went 0.328 -> 0.346 on SNOW (the lagging slip estimate lifted the reference)."""
    for terrain in terrains:
        for seed in (0, 5):
            kw = dict(duration_s=3.0, estimator=estimator)
            off = run_closed_loop(vehicle, terrain, "straight_accel", False, seed, **kw)[2]
            on = run_closed_loop(vehicle, terrain, "straight_accel", True, seed, **kw)[2]
            assert on["peak_slip"] <= off["peak_slip"] + 1e-9, (terrain, seed)


@pytest.mark.slow
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


@pytest.mark.parametrize("target_slip, radius, dt", [
    (1.0, 0.2, 0.02), (1.5, 0.2, 0.02), (float("nan"), 0.2, 0.02),
    (0.1, 0.0, 0.02), (0.1, -0.2, 0.02), (0.1, 0.2, -0.02), (0.1, 0.2, float("nan"))])
def test_feedforward_refuses_settings_with_no_limit_instead_of_clipping(
        target_slip, radius, dt):
    """A target slip of 1 or more was clipped to 0.99 without a word (target 1.5: limit
    v_ref / (0.01 r), 100 times the reference's wheel speed); a radius of 0 gave an infinite
    limit, a NaN target or time step a NaN limit and no correction."""
    with pytest.raises(ConfigError):
        feedforward_step(np.array([0.2]), np.array([0.2]), np.array([5.0]), 0.5, target_slip,
                         radius, dt)


@pytest.mark.parametrize("accel", [float("nan"), float("inf"), "1.0x", None])
def test_feedforward_refuses_an_acceleration_limit_that_is_not_a_finite_number(accel):
    """A NaN acceleration limit made the reference ground speed NaN, so the limit never bound
    (correction 0 for a wheel at 10 rad/s over a 0.5 m/s ground speed) and the NaN reference
    fed back into every later step: the feed-forward was off for good, unsaid. Text or None
    raised float()'s own ValueError / TypeError. Now a ConfigError naming accel_limit_m_s2."""
    with pytest.raises(ConfigError, match="accel_limit_m_s2"):
        feedforward_step(np.zeros(1), np.array([0.5]), np.array([10.0]), accel, 0.1, 0.1,
                         0.02)


@pytest.mark.parametrize("name,v_ref,v_est,engaged,shape", [
    ("v_ref_m_s", np.zeros(1), np.zeros(2), None, "(1,)"),          # broadcast, unsaid
    ("v_ref_m_s", np.zeros(3), np.zeros(2), None, "(3,)"),          # numpy's ValueError
    ("v_est_m_s", np.zeros(2), np.zeros(3), None, "(3,)"),
    ("v_est_m_s", np.zeros(2), 0.0, None, "()"),
    ("engaged", np.zeros(2), np.zeros(2), np.array([True]), "(1,)"),
])
def test_feedforward_refuses_arrays_not_of_the_commands_shape_naming_both(
        name, v_ref, v_est, engaged, shape):
    """A reference of shape (1,) beside a command of two wheels was broadcast without a
    word (both wheels limited from the one reference: correction -2.78 rad/s each); one of
    (3,) raised numpy's 'operands could not be broadcast together'. Now a ShapeError naming
    the argument, its shape and the command's."""
    from terrain.errors import ShapeError

    with pytest.raises(ShapeError, match=rf"{name} has shape {re.escape(shape)}, the "
                                         r"command omega_low_level_rad_s \(2,\)"):
        feedforward_step(v_ref, v_est, np.array([3.0, 3.0]), 1.0, 0.1, 0.1, 0.02, engaged)


@pytest.mark.parametrize("name,v_ref,omega", [
    ("omega_low_level_rad_s", np.zeros(2), np.array([float("nan"), 10.0])),
    ("omega_low_level_rad_s", np.zeros(2), np.array([float("inf"), 10.0])),
    ("v_ref_m_s", np.array([float("nan"), 0.0]), np.array([10.0, 10.0])),
])
def test_feedforward_refuses_a_non_finite_command_or_reference_naming_it(name, v_ref, omega):
    """A NaN low-level command made that wheel's reference ground speed NaN (min / max with a
    NaN rim speed), so its limit was NaN, never bound, and the NaN reference fed back into
    every later step: after one NaN command a wheel at 50 rad/s over a ground speed of 0 got
    correction 0 for good, unsaid (a NaN reference passed in did the same). Now an
    ImplausibleValueError naming the argument, as the traction step refuses a NaN command."""
    from terrain.errors import ImplausibleValueError

    with pytest.raises(ImplausibleValueError, match=name) as err:
        feedforward_step(v_ref, np.zeros(2), omega, 1.0, 0.1, 0.2, 0.02)
    assert err.value.column == name
