"""Properties of the AgriMaRo swerve kinematics (seed 001 eqs. 2.1-2.5, ch. 7.2 wheel
positions): inverse then forward returns the twist, every unit rolls without slip, the
k = 0 / k = 1 solutions of eq. 2.5 and the units that keep their angle."""

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from terrain.vehicles import AGRIMARO, swerve_forward, swerve_inverse, wheel_contact_velocity

R = AGRIMARO.wheel_radius_m
twists = st.tuples(st.floats(-3.0, 3.0), st.floats(-2.0, 2.0), st.floats(-2.0, 2.0))
angles = st.tuples(*(st.floats(-10.0, 10.0),) * 3)         # several turns: slip rings (ch. 2.2)


def _wrap(a):
    return (np.asarray(a) + np.pi) % (2.0 * np.pi) - np.pi


@pytest.mark.slow
@settings(deadline=None, max_examples=300)
@given(twist=twists, prev=angles)
def test_inverse_then_forward_returns_the_twist_and_every_unit_rolls(twist, prev):
    twist = np.array(twist)
    delta, omega = swerve_inverse(twist, delta_prev_rad=np.array(prev))
    # a unit slower than min_speed_m_s (1e-6 m/s) is left at rest: at most that much error
    np.testing.assert_allclose(swerve_forward(delta, omega), twist, rtol=0, atol=1e-5)
    vel = wheel_contact_velocity(AGRIMARO.positions, twist)
    speed = np.hypot(vel[:, 0], vel[:, 1])
    moving = speed >= 1e-6
    rolled = R * omega[:, None] * np.column_stack([np.cos(delta), np.sin(delta)])
    np.testing.assert_allclose(rolled[moving], vel[moving], rtol=0, atol=1e-12)
    # |omega| r is the contact speed, eq. 2.5, whichever solution is taken
    np.testing.assert_allclose(np.abs(omega[moving]) * R, speed[moving], rtol=1e-12)
    # of the two solutions (k = 0, 1: pi apart) the one within pi/2 of the previous angle
    assert (np.abs(_wrap(delta - np.array(prev)))[moving] <= np.pi / 2 + 1e-12).all()
    assert (np.abs(delta[moving]) <= np.pi).all()
    # a unit at rest keeps its previous angle and stops
    assert (delta[~moving] == np.array(prev)[~moving]).all() and (omega[~moving] == 0).all()


@settings(deadline=None, max_examples=100)
@given(twist=twists, unit=st.integers(0, 2), offset=st.floats(-1e-7, 1e-7))
def test_a_unit_at_or_next_to_the_instantaneous_centre_of_rotation(twist, unit, offset):
    # near-singular twists: choose v so that unit `unit` sits (almost) on the ICR
    yaw_rate = twist[0] if abs(twist[0]) > 0.1 else 0.5
    x, y = AGRIMARO.positions[unit]
    tw = np.array([yaw_rate, yaw_rate * y + offset, -yaw_rate * x])
    prev = np.array([0.3, -1.2, 2.0])
    delta, omega = swerve_inverse(tw, delta_prev_rad=prev)
    assert delta[unit] == prev[unit] and omega[unit] == 0.0
    np.testing.assert_allclose(swerve_forward(delta, omega), tw, rtol=0, atol=1e-6)


@settings(deadline=None, max_examples=100)
@given(delta=angles, omega=st.tuples(*(st.floats(-10.0, 10.0),) * 3))
def test_forward_is_blind_to_the_k_1_solution(delta, omega):
    # eq. 2.5: turning a unit by pi and reversing its wheel leaves the contact velocity
    d, w = np.array(delta), np.array(omega)
    flip = np.array([True, False, True])
    np.testing.assert_allclose(swerve_forward(np.where(flip, d + np.pi, d),
                                              np.where(flip, -w, w)),
                               swerve_forward(d, w), rtol=1e-9, atol=1e-12)


@pytest.mark.parametrize("twist, delta, sign", [
    ([0.0, 1.0, 0.0], 0.0, 1),                       # forward: k = 0
    ([0.0, -1.0, 0.0], 0.0, -1),                     # backward: k = 1, wheels reversed
    ([0.0, 0.0, 1.0], np.pi / 2, 1),                 # left, exactly 90 deg: k = 0 kept
    ([0.0, 0.0, -1.0], -np.pi / 2, 1),
    # 100 deg is beyond +-90: the k = 1 angle -80 deg with the wheel reversed
    ([0.0, np.cos(np.radians(100)), np.sin(np.radians(100))], np.radians(-80), -1),
])
def test_with_no_previous_angle_the_unit_turns_at_most_90_degrees(twist, delta, sign):
    d, w = swerve_inverse(np.array(twist))
    np.testing.assert_allclose(d, delta, atol=1e-12)
    np.testing.assert_allclose(w, sign * 1.0 / R, rtol=1e-12)      # 1 m/s over r, rad/s


def test_a_batch_with_its_previous_angles_equals_the_rows_one_by_one():
    rng = np.random.default_rng(1)
    tw = rng.uniform(-1.0, 1.0, (50, 3))
    prev = rng.uniform(-4.0, 4.0, (50, 3))
    d, w = swerve_inverse(tw, delta_prev_rad=prev)
    for i in range(50):
        di, wi = swerve_inverse(tw[i], delta_prev_rad=prev[i])
        np.testing.assert_array_equal(d[i], di)
        np.testing.assert_array_equal(w[i], wi)
    np.testing.assert_allclose(swerve_forward(d, w), tw, atol=1e-9)


def test_zero_twist_keeps_the_previous_angles():
    prev = np.array([0.4, -2.9, 7.0])
    d, w = swerve_inverse(np.zeros(3), delta_prev_rad=prev)
    np.testing.assert_array_equal(d, prev)
    np.testing.assert_array_equal(w, 0.0)
    d0, w0 = swerve_inverse(np.zeros(3))
    np.testing.assert_array_equal(d0, 0.0)
    np.testing.assert_array_equal(w0, 0.0)
