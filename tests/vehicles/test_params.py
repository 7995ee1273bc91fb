"""The vehicle parameter dataclasses refuse impossible values when built (ConfigError naming
the field), so a bad variant fails at construction, not as an inf or a ZeroDivisionError
deep in a simulation."""

from dataclasses import replace

import pytest

from terrain.errors import ConfigError
from terrain.vehicles import AGRIMARO, HUSKY, TRACKED, get_vehicle


@pytest.mark.parametrize("name", ["agrimaro", "husky", "tracked"])
def test_the_shipped_parameters_pass_their_own_checks(name):
    vehicle = get_vehicle(name)
    assert replace(vehicle) == vehicle
    assert replace(vehicle.motor) == vehicle.motor


@pytest.mark.parametrize("field, value", [
    ("efficiency", 1.2),                 # before: accepted, a current below the torque law's
    ("efficiency", 0.0),                 # before: accepted, current_from_torque gave inf
    ("torque_constant_nm_per_a", 0.0),
    ("gear_ratio", -78.71),
    ("no_load_current_a", -1.0),
    ("speed_time_constant_s", 0.0),      # before: ZeroDivisionError in the integrator
    ("speed_time_constant_s", -0.1),
    ("max_wheel_speed_rad_s", 0.0),
    ("encoder_filter_s", float("nan")),
    ("encoder_counts_per_rev", 0),       # before: ZeroDivisionError in encoder_count_rate
    ("encoder_counts_per_rev", 78.5),
    ("wheel_inertia_kg_m2", -0.06),
    ("gear_ratio", "78.71"),
])
def test_motor_params_refuse_impossible_values(field, value):
    with pytest.raises(ConfigError, match=f"MotorParams.{field}"):
        replace(HUSKY.motor, **{field: value})


@pytest.mark.parametrize("vehicle, field, value", [
    (HUSKY, "mass_kg", -50.0),            # before: accepted
    (HUSKY, "wheel_radius_m", 0.0),
    (HUSKY, "track_m", float("inf")),
    (HUSKY, "yaw_inertia_kg_m2", 0.0),
    (HUSKY, "contact_length_m", -0.08),
    (HUSKY, "speed_quantum_m_s", -0.01),
    (HUSKY, "wheels_per_motor", 0),
    (HUSKY, "motor", None),
    (TRACKED, "mass_kg", 0.0),
    (TRACKED, "sprocket_radius_m", 0.0),
    (TRACKED, "track_length_m", -0.6),
    (TRACKED, "n_segments", 0),          # before: ZeroDivisionError in contact_geometry
    (TRACKED, "slip_parameter_n", float("nan")),
    (AGRIMARO, "wheel_radius_m", 0.0),   # before: swerve_inverse gave omega inf
    (AGRIMARO, "mass_kg", -150.0),
    (AGRIMARO, "steering_rate_rad_s", 0.0),
    (AGRIMARO, "steering_dead_band_rad", -0.021),
    (AGRIMARO, "wheel_positions_m", ((0.0, 0.0), (1.0, 0.0))),
    (AGRIMARO, "wheel_positions_m", ((0.0, 0.0), (1.0, 0.0), (0.0, float("nan")))),
    (AGRIMARO, "camera_lever_arm_m", (0.6685, -0.26875)),
])
def test_vehicle_params_refuse_impossible_values(vehicle, field, value):
    with pytest.raises(ConfigError, match=f"{type(vehicle).__name__}.{field}"):
        replace(vehicle, **{field: value})


def test_encoder_quantum_and_drive_inertia_follow_their_definitions():
    import numpy as np
    from terrain.vehicles.common import drive_inertia_kg_m2
    # one count is a full turn over the counts per revolution
    for vehicle in (HUSKY, TRACKED, AGRIMARO):
        motor = vehicle.motor
        assert motor.encoder_quantum_rad * motor.encoder_counts_per_rev == pytest.approx(
            2 * np.pi)
    # a Husky motor turns the two wheels of its side (chained); a track one sprocket
    assert drive_inertia_kg_m2(HUSKY) == pytest.approx(2 * HUSKY.motor.wheel_inertia_kg_m2)
    assert drive_inertia_kg_m2(TRACKED) == pytest.approx(TRACKED.motor.wheel_inertia_kg_m2)
