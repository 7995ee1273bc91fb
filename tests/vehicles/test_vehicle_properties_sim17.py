"""Properties of the skid-steer kinematics, the ICR fits and the motor law (sim17 review).

* ICR round trip: the side speeds of a body twist (:func:`skid_steer_inverse`, the ICR model
  of Mandow et al. 2007, seed 000 eq. 2 with ``B = 2 d``) give that twist back through
  :func:`skid_steer_forward`, for any ``chi``; the compiled kernels (``register_jitable``
  :func:`body_rates`, :func:`side_speeds`, :func:`wrap_angle`; the numba ufunc
  :func:`wheel_rim_speed`) equal their NumPy reference;
* left/right mirror: swapping the sides reverses the yaw rate and keeps the speed; the ICR
  fits (:func:`inverse_icr_factor`, :func:`icr_expansion_factor`, :func:`chi_from_truth`)
  are blind to the mirror (a right turn expands as a left one);
* scaling: the fits are ratios, unchanged when every speed and yaw rate is scaled by one
  factor; :func:`chi_from_truth` of an exact ICR recording is its ``chi``, and
  ``icr_expansion_factor`` is the reciprocal of ``inverse_icr_factor``;
* the motor law is odd (reversing torque and speed reverses the current) and the power a
  drive delivers is never negative, ``|omega T| / eta`` plus the no-load loss while it drives.
"""

from __future__ import annotations

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st
from numba import njit
import pytest

from terrain.vehicles import HUSKY, TRACKED
from terrain.vehicles.common import wrap_angle
from terrain.vehicles.icr import chi_from_truth, icr_expansion_factor, inverse_icr_factor
from terrain.vehicles.skid_steer import (body_rates, side_speeds, skid_steer_forward,
                                         skid_steer_inverse)
from terrain.vehicles.swerve import point_velocity, wheel_rim_speed

speeds = st.floats(-3.0, 3.0)
rates = st.floats(-2.0, 2.0)
tracks = st.floats(0.1, 2.0)
chis = st.floats(1.0, 5.0)
# yaw rates 0 or at least 1e-3 rad/s: a subnormal one squares to 0 (x = 5e-324 gave a = inf)
fit_rates = st.one_of(st.just(0.0), st.floats(1e-3, 2.0), st.floats(-2.0, -1e-3))
samples = st.lists(st.tuples(speeds, fit_rates, fit_rates), min_size=1, max_size=30)


@njit(cache=False)
def _compiled_kinematics(v_l, v_r, track, chi, angle):
    v, w = body_rates(v_l, v_r, track, chi)
    left, right = side_speeds(v, w, track, chi)
    return v, w, left, right, wrap_angle(angle)


@settings(max_examples=200, deadline=None)
@given(v=speeds, w=rates, track=tracks, chi=chis)
def test_side_speeds_of_a_twist_give_the_twist_back(v, w, track, chi):
    left, right = skid_steer_inverse(np.array([v]), np.array([w]), track, chi)
    v2, w2 = skid_steer_forward(left, right, track, chi=chi)
    np.testing.assert_allclose([v2[0], w2[0]], [v, w], rtol=0, atol=1e-12)
    # the contact lines chi B apart: their difference is the yaw rate times chi B
    np.testing.assert_allclose(right - left, chi * track * w, rtol=1e-12, atol=1e-15)


@settings(max_examples=100, deadline=None)
@given(v_l=speeds, v_r=speeds, track=tracks, chi=chis, angle=st.floats(-100.0, 100.0))
def test_the_compiled_kinematics_equal_the_numpy_reference(v_l, v_r, track, chi, angle):
    got = _compiled_kinematics(v_l, v_r, track, chi, angle)
    v, w = body_rates(np.float64(v_l), np.float64(v_r), track, chi)
    left, right = side_speeds(v, w, track, chi)
    ref = (v, w, left, right, wrap_angle(np.float64(angle)))
    np.testing.assert_allclose(got, ref, rtol=1e-15, atol=1e-15)
    assert -np.pi <= got[4] < np.pi


@settings(max_examples=100, deadline=None)
@given(tw=st.tuples(speeds, speeds, rates), x=speeds, y=speeds, delta=st.floats(-7.0, 7.0))
def test_the_rim_speed_ufunc_is_the_point_velocity_along_the_wheel(tw, x, y, delta):
    # seed 001 eq. 4.20: the body velocity moved to (x, y), projected on delta
    u, v = point_velocity(tw[0], tw[1], tw[2], x, y)
    want = u * np.cos(delta) + v * np.sin(delta)
    got = wheel_rim_speed(tw[0], tw[1], tw[2], x, y, delta)
    np.testing.assert_allclose(got, want, rtol=1e-12, atol=1e-12)


@settings(max_examples=100, deadline=None)
@given(rows=samples, track=tracks, chi=chis)
def test_swapping_the_sides_reverses_the_yaw_rate_and_keeps_the_speed(rows, track, chi):
    vl, vr, _ = np.array(rows).T
    v, w = skid_steer_forward(vl, vr, track, chi=chi)
    v_m, w_m = skid_steer_forward(vr, vl, track, chi=chi)
    np.testing.assert_array_equal(v_m, v)
    np.testing.assert_array_equal(w_m, -w)


@pytest.mark.slow
@settings(max_examples=150, deadline=None)
@given(rows=samples, scale=st.floats(0.01, 100.0), mirror=st.booleans())
def test_icr_fits_are_blind_to_mirror_and_common_scale(rows, scale, mirror):
    _, x, y = np.array(rows).T          # commanded and measured yaw rates
    a = inverse_icr_factor(y, x)
    chi = icr_expansion_factor(y, x)
    s = -scale if mirror else scale
    np.testing.assert_allclose(inverse_icr_factor(s * y, s * x), a, rtol=1e-9, atol=1e-12)
    chi_s = icr_expansion_factor(s * y, s * x)
    if np.isfinite(chi):
        np.testing.assert_allclose(chi_s, chi, rtol=1e-9)
        # chi is the reciprocal of the slope a (no floor) where the vehicle turns the
        # commanded way
        np.testing.assert_allclose(chi, 1.0 / a, rtol=1e-9)
        assert chi > 0
    else:
        assert np.isnan(chi_s) if np.isnan(chi) else chi_s == np.inf


@settings(max_examples=150, deadline=None)
@given(rows=st.lists(st.tuples(speeds, st.floats(0.15, 2.0), st.booleans()), min_size=1,
                     max_size=30), track=tracks, chi=chis, scale=st.floats(0.1, 10.0))
def test_chi_from_truth_of_an_exact_icr_recording_is_its_chi(rows, track, chi, scale):
    v, w_abs, left_turn = np.array(rows, dtype=float).T
    w = np.where(left_turn > 0, w_abs, -w_abs)
    left, right = side_speeds(v, w, track, chi)
    np.testing.assert_allclose(chi_from_truth(left, right, w, track), chi, rtol=1e-9)
    # the mirrored recording (sides swapped, yaw reversed) and a scaled one: the same chi
    np.testing.assert_allclose(chi_from_truth(right, left, -w, track), chi, rtol=1e-9)
    np.testing.assert_allclose(chi_from_truth(scale * left, scale * right, scale * w, track,
                                              min_yaw_rate_rad_s=0.1 * scale), chi,
                               rtol=1e-9)


@settings(max_examples=100, deadline=None)
@given(torque=st.floats(-50.0, 50.0), omega=st.floats(-10.0, 10.0),
       motor=st.sampled_from((HUSKY.motor, TRACKED.motor)))
def test_the_motor_law_is_odd_and_its_power_never_negative(torque, omega, motor):
    cur = motor.current_from_torque(torque, omega)
    np.testing.assert_allclose(motor.current_from_torque(-torque, -omega), -cur,
                               rtol=1e-12, atol=1e-12)
    power = motor.drive_power_w(cur, omega)
    assert power >= 0.0
    if torque * omega >= 0:       # driving: mechanical power / eta plus the no-load loss
        k = motor.torque_constant_nm_per_a * motor.gear_ratio
        want = (abs(omega * torque) / motor.efficiency
                + k * abs(omega) * motor.no_load_current_a * abs(np.tanh(omega / 0.05)))
        np.testing.assert_allclose(power, want, rtol=1e-9, atol=1e-9)
