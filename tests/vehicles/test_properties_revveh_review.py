"""Review revveh: physical invariants of the vehicle kinematics and parameter sets that the
other vehicle tests do not pin (ICR position, speed scaling, left/right mirror of the swerve
drive, rigid-body constraint, rolling direction of each unit, camera round trip, contact
geometry layout)."""

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from terrain.errors import ConfigError
from terrain.vehicles import (AGRIMARO, HUSKY, TRACKED, ContactGeometry, HuskyParams,
                              TrackedParams, camera_to_robot_velocity, drive_inertia_kg_m2,
                              endo_slip_ratio_ratio, robot_to_camera_velocity,
                              skid_steer_forward, skid_steer_inverse, skid_steer_pose_rates,
                              swerve_forward, swerve_inverse, t265_tracking_to_robot,
                              wheel_contact_velocity)
from terrain.vehicles.common import wrap_angle

FAST = settings(max_examples=40, deadline=None)
speed = st.floats(-3.0, 3.0, allow_nan=False)
rate = st.floats(-2.0, 2.0, allow_nan=False)
chi = st.floats(0.5, 3.0)
track = st.floats(0.2, 2.0)
twist = st.tuples(rate, speed, speed).map(np.array)


@FAST
@given(v=speed, w=rate.filter(lambda x: abs(x) > 1e-3), b=track, c=chi)
def test_side_speeds_are_the_yaw_rate_times_the_distance_to_the_icr(v, w, b, c):
    # ICR on the body y axis at R = v / w; each contact line (at +-chi B / 2) moves at
    # yaw_rate times its signed distance from it (Mandow et al. 2007)
    vl, vr = skid_steer_inverse(np.array([v]), np.array([w]), b, c)
    r_icr = v / w
    np.testing.assert_allclose(vl, w * (r_icr - c * b / 2.0), atol=1e-12)
    np.testing.assert_allclose(vr, w * (r_icr + c * b / 2.0), atol=1e-12)
    # a contact line at the ICR stands still
    vl0, _ = skid_steer_inverse(np.array([w * c * b / 2.0]), np.array([w]), b, c)
    assert abs(vl0[0]) < 1e-12


@FAST
@given(vl=speed, vr=speed, el=st.floats(0.0, 1.0), er=st.floats(0.0, 1.0), b=track, c=chi,
       k=st.floats(-4.0, 4.0))
def test_skid_steer_forward_is_linear_in_the_speeds_and_applies_the_efficiencies(
        vl, vr, el, er, b, c, k):
    v1, w1 = skid_steer_forward([vl], [vr], b, el, er, c)
    v2, w2 = skid_steer_forward([el * vl], [er * vr], b, 1.0, 1.0, c)
    np.testing.assert_array_equal(v1, v2)
    np.testing.assert_array_equal(w1, w2)
    vk, wk = skid_steer_forward([k * vl], [k * vr], b, el, er, c)
    np.testing.assert_allclose(vk, k * v1, atol=1e-12)
    np.testing.assert_allclose(wk, k * w1, atol=1e-12)
    # a larger chi turns slower by exactly its ratio; the speed does not depend on chi
    v3, w3 = skid_steer_forward([vl], [vr], b, el, er, 2.0 * c)
    np.testing.assert_array_equal(v3, v1)
    np.testing.assert_allclose(w3, w1 / 2.0, rtol=1e-12, atol=1e-300)


@FAST
@given(yaw=st.floats(-10.0, 10.0), v=speed, w=rate)
def test_pose_rates_move_at_the_body_speed_along_the_heading(yaw, v, w):
    r = skid_steer_pose_rates([yaw], [v], [w])[0]
    assert np.hypot(r[0], r[1]) == pytest.approx(abs(v), abs=1e-12)
    assert r[0] * -np.sin(yaw) + r[1] * np.cos(yaw) == pytest.approx(0.0, abs=1e-12)
    assert r[2] == w


@FAST
@given(vl=speed.filter(lambda x: abs(x) > 1e-2), vr=speed.filter(lambda x: abs(x) > 1e-2),
       n=st.floats(0.0, 2.0))
def test_endo_ratio_of_the_swapped_tracks_is_its_reciprocal(vl, vr, n):
    # seed 003 eq. 27: alpha_l / alpha_r and alpha_r / alpha_l multiply to 1 (sgn^2 |.|^0)
    a = endo_slip_ratio_ratio([vl], [vr], n)[0]
    b = endo_slip_ratio_ratio([vr], [vl], n)[0]
    assert a * b == pytest.approx(1.0, rel=1e-12)
    # n = 1: the plain speed ratio, opposite in sign to the product of the speeds
    assert endo_slip_ratio_ratio([vl], [vr], 1.0)[0] == pytest.approx(-vr / vl, rel=1e-12)


def _mirror(tw):
    """The AgriMaRo mirrored in its body y axis (x -> -x): wheels 1 and 2 swap, wheel 3 stays;
    a twist (yaw_rate, v_x, v_y) becomes (-yaw_rate, -v_x, v_y)."""
    return np.array([-tw[0], -tw[1], tw[2]])


@FAST
@given(tw=twist)
def test_the_swerve_drive_is_symmetric_about_its_y_axis(tw):
    # ch. 7.2 geometry: d_1 = -d_2 on the x axis, d_3 on the y axis
    vel = wheel_contact_velocity(AGRIMARO.positions, tw)
    mirrored = wheel_contact_velocity(AGRIMARO.positions, _mirror(tw))
    flip = np.array([-1.0, 1.0])
    np.testing.assert_allclose(mirrored[[1, 0, 2]], vel * flip, atol=1e-12)
    # the forward kinematics of the mirrored wheel readings is the mirrored twist
    d, w = swerve_inverse(tw, min_speed_m_s=0.0)     # (a unit below 1e-6 m/s stands)
    dm = wrap_angle(np.pi - d[[1, 0, 2]])
    np.testing.assert_allclose(swerve_forward(dm, w[[1, 0, 2]]), _mirror(tw), atol=1e-9)


@FAST
@given(tw=twist)
def test_every_pair_of_wheels_keeps_its_distance(tw):
    # rigid body: the velocities of two points projected on the line joining them agree
    vel = wheel_contact_velocity(AGRIMARO.positions, tw)
    p = AGRIMARO.positions
    for i, j in ((0, 1), (0, 2), (1, 2)):
        e = p[j] - p[i]
        assert vel[i] @ e == pytest.approx(vel[j] @ e, abs=1e-9)


@FAST
@given(tw=twist, prev=st.tuples(*[st.floats(-np.pi, np.pi)] * 3).map(np.array))
def test_each_unit_rolls_along_its_contact_velocity_within_90_degrees_of_its_last_angle(
        tw, prev):
    d, w = swerve_inverse(tw, delta_prev_rad=prev, min_speed_m_s=1e-9)
    vel = wheel_contact_velocity(AGRIMARO.positions, tw)
    rolled = AGRIMARO.wheel_radius_m * w[:, None] * np.column_stack([np.cos(d), np.sin(d)])
    np.testing.assert_allclose(rolled, vel, atol=1e-9)
    moving = np.hypot(vel[:, 0], vel[:, 1]) > 1e-9
    assert (np.abs(wrap_angle(d - prev))[moving] <= np.pi / 2 + 1e-12).all()


@FAST
@given(tw=twist, k=st.floats(0.01, 10.0))
def test_scaling_the_twist_scales_the_wheel_speeds_and_keeps_the_angles(tw, k):
    d1, w1 = swerve_inverse(tw, min_speed_m_s=0.0)
    dk, wk = swerve_inverse(k * tw, min_speed_m_s=0.0)
    moving = np.abs(w1) > 1e-6
    np.testing.assert_allclose(wrap_angle(dk - d1)[moving], 0.0, atol=1e-9)
    np.testing.assert_allclose(wk, k * w1, rtol=1e-9, atol=1e-12)
    np.testing.assert_allclose(swerve_forward(dk, wk), k * tw, atol=1e-9 * (1 + k))


@FAST
@given(w=rate.filter(lambda x: abs(x) > 1e-2), cx=st.floats(-2.0, 2.0),
       cy=st.floats(-2.0, 2.0))
def test_a_rotation_about_any_point_leaves_that_point_still(w, cx, cy):
    # twist of a rotation about (cx, cy): v = -omega x c
    tw = np.array([w, w * cy, -w * cx])
    still = wheel_contact_velocity(np.array([[cx, cy]]), tw)[0]
    np.testing.assert_allclose(still, 0.0, atol=1e-12)
    d, om = swerve_inverse(tw, min_speed_m_s=0.0)    # (a wheel at the centre: 0 m/s)
    np.testing.assert_allclose(swerve_forward(d, om), tw, atol=1e-9)
    # each wheel moves perpendicular to its arm from the centre
    vel = wheel_contact_velocity(AGRIMARO.positions, tw)
    arms = AGRIMARO.positions - [cx, cy]
    np.testing.assert_allclose(np.sum(vel * arms, axis=1), 0.0, atol=1e-9)


@FAST
@given(v=st.tuples(speed, speed, speed).map(np.array),
       w=st.tuples(rate, rate, rate).map(np.array),
       arm=st.tuples(*[st.floats(-1.0, 1.0)] * 3).map(np.array))
def test_camera_and_robot_velocities_invert_each_other(v, w, arm):
    there = robot_to_camera_velocity(v, w, arm)
    np.testing.assert_allclose(camera_to_robot_velocity(there, w, arm), v, atol=1e-12)
    # the lever arm adds no speed along the rotation axis
    assert (there - v) @ w == pytest.approx(0.0, abs=1e-12)


@FAST
@given(vec=st.tuples(*[st.floats(-5.0, 5.0)] * 3).map(np.array))
def test_the_t265_axes_change_keeps_lengths(vec):
    out = t265_tracking_to_robot(vec)
    assert np.linalg.norm(out) == pytest.approx(np.linalg.norm(vec), rel=1e-12, abs=1e-15)
    # tracking y (up) is robot z (up), tracking z (backward) is robot -x
    np.testing.assert_array_equal(t265_tracking_to_robot([0.0, 1.0, 0.0]), [0.0, 0.0, 1.0])
    np.testing.assert_array_equal(t265_tracking_to_robot([0.0, 0.0, 1.0]), [-1.0, -0.0, 0.0])


@FAST
@given(b=st.floats(0.3, 2.0), length=st.floats(0.3, 2.0), frac=st.floats(0.05, 0.95))
def test_husky_contacts_span_the_track_and_wheelbase_around_the_origin(b, length, frac):
    h = HuskyParams(track_m=b, wheelbase_m=length, contact_width_m=frac * b,
                    contact_length_m=frac * length)
    g = h.contact_geometry()
    assert np.ptp(g.positions_m[:, 1]) == pytest.approx(b)
    assert np.ptp(g.positions_m[:, 0]) == pytest.approx(length)
    np.testing.assert_array_equal(g.cog_m, [0.0, 0.0])
    # motor 0 (left) drives exactly the contacts with y > 0
    np.testing.assert_array_equal(g.motor_of_contact == 0, g.positions_m[:, 1] > 0)


@FAST
@given(n=st.integers(1, 40), length=st.floats(0.1, 2.0))
def test_track_segments_are_symmetric_and_span_the_track_less_one_piece(n, length):
    t = TrackedParams(n_segments=n, track_length_m=length)
    g = t.contact_geometry()
    xs = g.positions_m[:n, 0]
    np.testing.assert_allclose(xs, -xs[::-1], atol=1e-12)
    assert np.ptp(xs) == pytest.approx(length * (1.0 - 1.0 / n), abs=1e-12)
    np.testing.assert_allclose(g.cog_m, 0.0, atol=1e-12)
    assert g.load_share.sum() == pytest.approx(1.0)


@pytest.mark.parametrize("vehicle, per_motor", [(HUSKY, 2), (TRACKED, 1), (AGRIMARO, 1)])
def test_drive_inertia_is_the_wheel_inertia_times_the_wheels_of_a_motor(vehicle, per_motor):
    assert vehicle.wheels_per_motor == per_motor
    assert drive_inertia_kg_m2(vehicle) == vehicle.motor.wheel_inertia_kg_m2 * per_motor
    doubled = type(vehicle)(wheels_per_motor=2 * per_motor)
    assert drive_inertia_kg_m2(doubled) == 2.0 * drive_inertia_kg_m2(vehicle)


@pytest.mark.parametrize("excess, ok", [(1e-12, True), (-1e-12, True), (1e-6, False),
                                        (-1e-6, False), (5e-4, False)])
def test_load_shares_must_sum_to_one_to_rounding_only(excess, ok):
    # a geometry 0.05 % heavier than the vehicle (shares summing to 1.0005) is refused; the
    # rounding of n equal shares 1/n is not
    share = np.full(4, 0.25)
    share[0] += excess
    g = HUSKY.contact_geometry()

    def make():
        return ContactGeometry(positions_m=g.positions_m, motor_of_contact=g.motor_of_contact,
                               load_share=share, steered=False, wheel_radius_m=0.1,
                               motor_names=g.motor_names)

    if ok:
        assert make().load_share.sum() == pytest.approx(1.0, abs=1e-11)
    else:
        with pytest.raises(ConfigError, match="load_share"):
            make()
