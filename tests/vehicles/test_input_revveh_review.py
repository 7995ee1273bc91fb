"""Review revveh: bad input to the swerve kinematics, the motor law and the vehicle helpers
gets a typed error naming the argument (it was a bare NumPy/Python error, or a silent
answer: booleans read as 1 rad or 1 m/s, text parsed as numbers)."""

import numpy as np
import pytest

from terrain.errors import ConfigError, EstimationError, NonFiniteInputError
from terrain.vehicles import (AGRIMARO, HUSKY, TRACKED, camera_to_robot_velocity,
                              contact_geometry, drive_inertia_kg_m2, robot_to_camera_velocity,
                              skid_steer_forward, skid_steer_inverse, swerve_forward,
                              swerve_inverse, t265_tracking_to_robot, wheel_contact_velocity)
from terrain.vehicles.icr import icr_expansion_factor


@pytest.mark.parametrize("call, name", [
    (lambda bad: swerve_forward(bad, [1.0, 1.0, 1.0]), "delta_rad"),
    (lambda bad: swerve_forward([0.0, 0.0, 0.0], bad), "omega_rad_s"),
    (lambda bad: swerve_inverse(bad), "twist"),
    (lambda bad: swerve_inverse([0.0, 1.0, 0.0], delta_prev_rad=bad), "delta_prev_rad"),
    (lambda bad: wheel_contact_velocity(AGRIMARO.positions, bad), "twist"),
    (lambda bad: camera_to_robot_velocity(bad, [0.0, 0.0, 1.0]), "velocity"),
    (lambda bad: camera_to_robot_velocity([1.0, 0.0, 0.0], bad), "omega_rad_s"),
    (lambda bad: robot_to_camera_velocity([1.0, 0.0, 0.0], [0.0, 0.0, 1.0], bad),
     "lever_arm_m"),
    (lambda bad: t265_tracking_to_robot(bad), "vectors"),
])
@pytest.mark.parametrize("bad", [[True, False, True], ["a", "b", "c"], ["0", "1", "0"]],
                         ids=["booleans", "text", "numeric-text"])
def test_swerve_kinematics_refuse_booleans_and_text_naming_the_argument(call, name, bad):
    # booleans were angles of 1 rad / speeds of 1 m/s, "0" was parsed as 0, "a" raised
    # NumPy's bare ValueError (camera_to_robot_velocity: a bare TypeError on negation)
    with pytest.raises(EstimationError, match=name):
        call(bad)


def test_wheel_positions_of_text_or_booleans_are_refused_naming_them():
    with pytest.raises(EstimationError, match="positions_m"):
        wheel_contact_velocity([["a", "b"]], [0.0, 1.0, 0.0])
    with pytest.raises(EstimationError, match="positions_m"):
        wheel_contact_velocity([[True, False]], [0.0, 1.0, 0.0])


@pytest.mark.parametrize("bad", [np.nan, np.inf, -np.inf])
def test_swerve_forward_refuses_a_non_finite_wheel_reading(bad):
    # one NaN wheel made the whole least-squares twist NaN without a word
    delta = np.zeros((4, 3))
    omega = np.ones((4, 3))
    omega[2, 1] = bad
    with pytest.raises(NonFiniteInputError, match=r"omega_rad_s.*\b2\b"):
        swerve_forward(delta, omega)
    with pytest.raises(NonFiniteInputError, match="delta_rad"):
        swerve_forward(omega * bad, delta)


@pytest.mark.parametrize("bad", [np.nan, np.inf])
def test_swerve_inverse_refuses_a_non_finite_twist(bad):
    # NaN gave NaN steering angles and wheel speeds (a NaN unit did not even keep its angle)
    with pytest.raises(NonFiniteInputError, match="twist"):
        swerve_inverse([0.0, bad, 0.0])


@pytest.mark.parametrize("method, args, name", [
    ("current_from_torque", (True, 1.0), "wheel_torque_nm"),
    ("current_from_torque", (1.0, "x"), "omega_rad_s"),
    ("current_from_torque", ("1", 1.0), "wheel_torque_nm"),
    ("drive_power_w", ([True], 1.0), "current_a"),
    ("drive_power_w", (1.0, "a"), "omega_rad_s"),
    ("rotation_direction", ("a",), "omega_rad_s"),
    ("rotation_direction", (np.array([True]),), "omega_rad_s"),
])
def test_motor_law_refuses_booleans_and_text_naming_the_argument(method, args, name):
    # True was a torque of 1 N m (a current of 1.36 A), text a bare ValueError
    with pytest.raises(EstimationError, match=name):
        getattr(HUSKY.motor, method)(*args)


@pytest.mark.parametrize("bad", [None, HUSKY.motor, "husky"])
def test_drive_inertia_and_contact_geometry_refuse_what_is_not_a_vehicle(bad):
    # AttributeError 'NoneType' object has no attribute 'motor' before
    with pytest.raises(ConfigError, match="vehicle"):
        drive_inertia_kg_m2(bad)
    with pytest.raises(ConfigError, match="params"):
        contact_geometry(bad)


def test_valid_inputs_still_give_the_documented_values():
    assert drive_inertia_kg_m2(HUSKY) == 0.12 and drive_inertia_kg_m2(TRACKED) == 0.01
    assert contact_geometry(AGRIMARO).n_motors == 3
    twist = np.array([0.3, 1.0, -0.2])
    d, w = swerve_inverse(twist)
    np.testing.assert_allclose(swerve_forward(d, w), twist, atol=1e-12)
    assert HUSKY.motor.current_from_torque(0.0, 1e9) == pytest.approx(1.0)


@pytest.mark.parametrize("call, name", [
    (lambda bad: skid_steer_forward(bad, [1.0], 0.5), "v_left_m_s"),
    (lambda bad: skid_steer_inverse([1.0], bad, 0.5), "yaw_rate_rad_s"),
    (lambda bad: icr_expansion_factor(bad, [1.0]), "yaw_rate_rad_s"),
])
@pytest.mark.parametrize("bad", [["0.5"], [None], None],
                         ids=["numeric-text", "None-in-list", "None"])
def test_skid_steer_and_icr_refuse_numeric_text_and_none(call, name, bad):
    # NumPy parsed "0.5" as 0.5 and None as NaN: a silent speed, or a silent NaN chi
    with pytest.raises(EstimationError, match=name):
        call(bad)
