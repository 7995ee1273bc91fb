import numpy as np
import pytest

from terrain.errors import ConfigError
from terrain.vehicles import (AGRIMARO, HUSKY, TRACKED, camera_to_robot_velocity,
                              endo_slip_ratio_ratio, get_vehicle, robot_to_camera_velocity,
                              skid_steer_forward, skid_steer_inverse, swerve_forward,
                              swerve_inverse, t265_tracking_to_robot, wheel_contact_velocity)
from terrain.vehicles.swerve import h_matrix


def test_thesis_geometry_values():
    assert np.allclose(AGRIMARO.positions, [[-0.5075, 0.0], [0.5075, 0.0], [0.0, -0.756]])
    assert AGRIMARO.camera_lever_arm_m == (0.6685, -0.26875, 0.0)
    assert AGRIMARO.steering_dead_band_rad == pytest.approx(0.021)
    assert HUSKY.track_m == pytest.approx(0.5708) and HUSKY.wheelbase_m == pytest.approx(0.512)
    assert TRACKED.track_m == pytest.approx(0.393) and TRACKED.mass_kg == 25.0


def test_h_matrix_matches_eq_2_3_layout():
    # eq. 2.3 with wheel 1 at (w/2, 0), wheel 2 at (-w/2, 0), wheel 3 at (0, -t)
    w, t = 1.015, 0.756
    h = h_matrix(np.array([[w / 2, 0.0], [-w / 2, 0.0], [0.0, -t]]))
    expected = np.array([[0, 1, 0], [w / 2, 0, 1], [0, 1, 0], [-w / 2, 0, 1], [t, 1, 0],
                         [0, 0, 1]])
    assert np.allclose(h, expected)


def test_swerve_inverse_forward_round_trip():
    rng = np.random.default_rng(0)
    twists = rng.uniform(-1, 1, (200, 3))
    delta, omega = swerve_inverse(twists)
    back = swerve_forward(delta, omega)
    assert np.allclose(back, twists, atol=1e-9)
    # the chosen solutions satisfy pure rolling at every wheel (eq. 2.1 = eq. 2.2)
    vel = wheel_contact_velocity(AGRIMARO.positions, twists)
    rolled = AGRIMARO.wheel_radius_m * omega[..., None] * np.stack(
        [np.cos(delta), np.sin(delta)], axis=-1)
    assert np.allclose(rolled, vel, atol=1e-9)


def test_swerve_inverse_picks_solution_near_previous_angle():
    tw = np.array([0.0, 1.0, 0.0])                       # straight ahead
    d0, w0 = swerve_inverse(tw)
    assert np.allclose(d0, 0.0) and np.all(w0 > 0)
    d1, w1 = swerve_inverse(tw, delta_prev_rad=np.full(3, 3.0))
    assert np.allclose(np.abs(d1), np.pi) and np.all(w1 < 0)


def test_pure_rotation_wheels_perpendicular_to_arm():
    d, _ = swerve_inverse(np.array([0.5, 0.0, 0.0]))
    e = np.column_stack([np.cos(d), np.sin(d)])
    assert np.allclose(np.sum(e * AGRIMARO.positions, axis=1), 0.0, atol=1e-12)


def test_camera_lever_arm_poisson_formula():
    omega = np.array([0.0, 0.0, 1.0])
    v_cam = robot_to_camera_velocity(np.zeros(3), omega)
    assert np.allclose(v_cam, [0.26875, 0.6685, 0.0])
    v = np.array([0.4, -0.1, 0.0])
    assert np.allclose(camera_to_robot_velocity(robot_to_camera_velocity(v, omega), omega), v)


def test_t265_tracking_axes():
    # tracking z points backward, x right, y up
    out = t265_tracking_to_robot(np.array([[0, 0, 1.0], [1.0, 0, 0], [0, 1.0, 0]]))
    assert np.allclose(out, [[-1, 0, 0], [0, -1, 0], [0, 0, 1]])


def test_skid_steer_round_trip_and_icr():
    v, r = np.array([0.5, -0.2]), np.array([0.3, 1.0])
    vl, vr = skid_steer_inverse(v, r, HUSKY.track_m, chi=1.5)
    v2, r2 = skid_steer_forward(vl, vr, HUSKY.track_m, chi=1.5)
    assert np.allclose(v2, v) and np.allclose(r2, r)
    _, r_ideal = skid_steer_forward(vl, vr, HUSKY.track_m)
    assert np.allclose(r_ideal, 1.5 * r)
    # eq. 5: slip efficiencies scale the side speeds
    v3, r3 = skid_steer_forward(1.0, 1.0, 0.5, eta_left=0.8, eta_right=1.0)
    assert v3 == pytest.approx(0.9) and r3 == pytest.approx(0.4)


def test_endo_ratio():
    assert endo_slip_ratio_ratio(1.0, 1.0) == pytest.approx(-1.0)
    assert endo_slip_ratio_ratio(-1.0, 2.0) == pytest.approx(2.0 ** 0.847)


def test_unknown_vehicle_lists_choices():
    with pytest.raises(ConfigError, match="agrimaro, husky, tracked"):
        get_vehicle("tank")


def test_contact_geometry_loads_sum_to_one():
    for name in ("agrimaro", "husky", "tracked"):
        g = get_vehicle(name).contact_geometry()
        assert g.load_share.sum() == pytest.approx(1.0)
        assert len(g.positions_m) == len(g.motor_of_contact)


@pytest.mark.parametrize("name", ["husky", "agrimaro", "tracked"])
def test_drive_power_is_the_shaft_power_over_efficiency_plus_the_no_load_loss(name):
    # back-EMF k_t G |omega| times the motor-law current (no winding resistance): what a PWM
    # drive passes to the motor, far below V_bus |I| at low speed
    from terrain.vehicles import get_vehicle
    motor = get_vehicle(name).motor
    omega = np.array([0.5, 3.0, 6.0, -4.0])
    torque = np.array([2.0, 5.0, 1.0, -3.0])
    current = motor.current_from_torque(torque, omega)
    expected = (np.abs(omega * torque) / motor.efficiency
                + motor.torque_constant_nm_per_a * motor.gear_ratio * np.abs(omega)
                * motor.no_load_current_a * np.abs(np.tanh(omega / 0.05)))
    np.testing.assert_allclose(motor.drive_power_w(current, omega), expected, rtol=1e-12)
    assert (motor.drive_power_w(current, omega) >= 0).all()
    assert motor.drive_power_w(np.abs(current), omega) == pytest.approx(
        motor.drive_power_w(current, omega))
