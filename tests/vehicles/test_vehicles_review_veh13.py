"""Review veh13 (vehicles): hand mutants that survived every test of tests/vehicles, and the
shapes the swerve kinematics and Endo's ratio accept."""

from __future__ import annotations

import numpy as np
import pytest

from terrain.vehicles import (AGRIMARO, HUSKY, TRACKED, AgriMaRoParams, get_vehicle,
                              swerve_forward, swerve_inverse)
from terrain.vehicles.icr import inverse_icr_factor


@pytest.mark.parametrize("name, steered, motors", [
    ("agrimaro", True, ("1", "2", "3")),       # three steered swerve units (seed 001)
    ("husky", False, ("left", "right")),        # fixed wheels along x
    ("tracked", False, ("left", "right")),
])
def test_only_the_swerve_drive_has_steered_contacts(name, steered, motors):
    # mutants steered=False on AgriMaRo / steered=True on the Husky survived
    g = get_vehicle(name).contact_geometry()
    assert g.steered is steered
    assert g.motor_names == motors and g.n_motors == len(motors)


@pytest.mark.parametrize("vehicle, radius", [(HUSKY, 0.1651), (TRACKED, 0.05),
                                             (AGRIMARO, 0.165)],
                         ids=["husky", "tracked", "agrimaro"])
def test_the_contact_geometry_rolls_on_the_vehicle_wheel_radius(vehicle, radius):
    # the tracked vehicle rolls on its 0.05 m sprocket (mutant: its 0.15 m track width)
    assert vehicle.wheel_radius_m == pytest.approx(radius, rel=1e-12)
    assert vehicle.contact_geometry().wheel_radius_m == pytest.approx(radius, rel=1e-12)


@pytest.mark.parametrize("vehicle, top_speed_m_s", [(HUSKY, 1.0), (TRACKED, 0.5),
                                                    (AGRIMARO, 1.6)],
                         ids=["husky", "tracked", "agrimaro"])
def test_the_wheel_speed_limit_is_the_documented_top_speed_at_the_rim(vehicle, top_speed_m_s):
    # Husky 1.0 m/s (datasheet), tracked 0.5 m/s and AgriMaRo 1.6 m/s (MotorParams.source):
    # omega_max r; 1 / 0.165 for the Husky (a 0.3 % faster robot) survived
    motor = vehicle.motor
    assert motor.max_wheel_speed_rad_s * vehicle.wheel_radius_m == pytest.approx(
        top_speed_m_s, rel=1e-12)


def test_get_vehicle_is_case_insensitive():
    # the docstring says case-insensitive; dropping .lower() survived
    assert get_vehicle("Husky") is HUSKY
    assert get_vehicle("AGRIMARO") is AGRIMARO
    assert get_vehicle("Tracked") is TRACKED


def test_swerve_wheels_on_one_line_are_a_valid_geometry():
    # two distinct steering axes fix the rigid-body twist (eq. 2.4): three units on the line
    # x = 0 are accepted and their kinematics round trip (mutant: every coordinate had to
    # vary, which refused this vehicle)
    on_a_line = AgriMaRoParams(wheel_positions_m=((0.0, 0.5), (0.0, -0.5), (0.0, 0.0)))
    twists = np.array([[0.4, 0.8, -0.2], [-0.3, 0.0, 0.5]])
    delta, omega = swerve_inverse(twists, on_a_line)
    np.testing.assert_allclose(swerve_forward(delta, omega, on_a_line), twists, atol=1e-12)


def test_swerve_inverse_accepts_a_zero_minimum_speed():
    # min_speed_m_s is ">= 0": 0 = no unit keeps its angle (mutant: 0 refused); a unit
    # exactly on the instantaneous centre of rotation has speed 0 and a wheel at rest
    x, y = AGRIMARO.positions[2]
    twist = np.array([0.5, 0.5 * y, -0.5 * x])         # unit 3 on the ICR
    prev = np.array([0.3, -0.2, 1.0])
    delta, omega = swerve_inverse(twist, delta_prev_rad=prev, min_speed_m_s=0.0)
    assert omega[2] == 0.0
    np.testing.assert_allclose(swerve_forward(delta, omega), twist, atol=1e-12)


def test_inverse_icr_factor_of_one_window_is_a_python_float():
    # "ndarray, shape (...), or float": one window gives a float, not a 0-d array
    x = np.linspace(-0.5, 0.5, 11)
    a = inverse_icr_factor(x / 1.5, x)
    assert type(a) is float and a == pytest.approx(1 / 1.5)


@pytest.mark.parametrize("twist", [np.array([0.0, 1.0, 0.0, 5.0]), np.array([0.0, 1.0]),
                                   np.zeros((4, 2)), np.float64(1.0)])
def test_a_twist_that_is_not_yaw_rate_vx_vy_is_a_shape_error(twist):
    from terrain.errors import ShapeError
    from terrain.vehicles import wheel_contact_velocity

    # [yaw_rate, v_x, v_y, 5.0] steered every unit straight ahead at 1 m/s (the fourth entry
    # dropped without a word); two entries gave NumPy's bare "could not be broadcast"
    with pytest.raises(ShapeError, match="twist"):
        wheel_contact_velocity(AGRIMARO.positions, twist)
    with pytest.raises(ShapeError, match="twist"):
        swerve_inverse(twist)


@pytest.mark.parametrize("positions", [np.zeros((3, 3)), np.zeros(3), np.zeros((3, 1))])
def test_wheel_positions_that_are_not_x_y_pairs_are_a_shape_error(positions):
    from terrain.errors import ShapeError
    from terrain.vehicles import wheel_contact_velocity

    # (x, y, z) positions were read as (x, y) with z dropped, a flat array raised IndexError
    with pytest.raises(ShapeError, match="positions_m"):
        wheel_contact_velocity(positions, np.array([0.1, 1.0, 0.0]))


def test_previous_steering_angles_of_another_shape_are_a_shape_error():
    from terrain.errors import ShapeError

    # two previous angles for three units raised NumPy's bare broadcast ValueError
    with pytest.raises(ShapeError, match="delta_prev_rad"):
        swerve_inverse(np.zeros((5, 3)), delta_prev_rad=np.zeros(2))
    # one angle for every unit still broadcasts
    delta, _ = swerve_inverse(np.zeros((5, 3)), delta_prev_rad=0.4)
    np.testing.assert_array_equal(delta, 0.4)


@pytest.mark.parametrize("bad", [float("nan"), float("inf")])
def test_a_non_finite_previous_steering_angle_is_refused(bad):
    from terrain.errors import NonFiniteInputError

    # "the solution closest to delta_prev_rad": with NaN neither is closer, so the unit took
    # the k = 0 angle whatever it steered before, and a standing unit kept NaN as its
    # angle; inf did the same with a RuntimeWarning
    prev = np.array([3.0, bad, 3.0])
    with pytest.raises(NonFiniteInputError, match=r"delta_prev_rad.*1 "):
        swerve_inverse(np.array([0.0, 1.0, 0.0]), delta_prev_rad=prev)
    with pytest.raises(NonFiniteInputError, match="delta_prev_rad"):
        swerve_inverse(np.zeros(3), delta_prev_rad=prev)


def test_chi_from_truth_of_a_recording_with_a_missing_yaw_rate_is_unknown():
    from terrain.vehicles.icr import chi_from_truth

    # a NaN side speed gave NaN, but a NaN yaw rate was dropped with the slow samples
    # (|NaN| > 0.1 is False): chi 1.5 from the rest, as if the recording were complete
    track, chi = 0.5, 1.5
    w = np.array([0.5, -0.4, 0.8, 0.6])
    left, right = -0.5 * chi * track * w, 0.5 * chi * track * w
    assert chi_from_truth(left, right, w, track) == pytest.approx(chi, rel=1e-12)
    w_gap = w.copy()
    w_gap[2] = np.nan
    assert np.isnan(chi_from_truth(left, right, w_gap, track))
    right_gap = right.copy()
    right_gap[2] = np.nan
    assert np.isnan(chi_from_truth(left, right_gap, w, track))


def test_skid_steer_arrays_of_different_lengths_are_a_shape_error():
    from terrain.errors import ShapeError
    from terrain.vehicles import (endo_slip_ratio_ratio, skid_steer_forward, skid_steer_inverse,
                                  skid_steer_pose_rates)

    # each raised NumPy's bare "operands could not be broadcast" (or np.stack's "all input
    # arrays must have the same shape") ValueError
    three, two = np.ones(3), np.ones(2)
    with pytest.raises(ShapeError, match=r"v_left_m_s \(3,\).*v_right_m_s \(2,\)"):
        skid_steer_forward(three, two, 0.5)
    with pytest.raises(ShapeError, match=r"eta_right \(2,\)"):
        skid_steer_forward(three, three, 0.5, eta_right=two)
    with pytest.raises(ShapeError, match=r"yaw_rate_rad_s \(2,\)"):
        skid_steer_inverse(three, two, 0.5)
    with pytest.raises(ShapeError, match=r"v_right_m_s \(2,\)"):
        endo_slip_ratio_ratio(three, two)
    with pytest.raises(ShapeError, match=r"v_m_s \(2,\)"):
        skid_steer_pose_rates(three, two, three)
    # a single number still stands for every sample
    v, r = skid_steer_forward(three, 2.0, 0.5, eta_left=0.9)
    np.testing.assert_allclose(r, (2.0 - 0.9) / 0.5)
    rates = skid_steer_pose_rates(np.array([0.0, np.pi / 2]), 1.0, 0.3)
    np.testing.assert_allclose(rates, [[1.0, 0.0, 0.3], [0.0, 1.0, 0.3]], atol=1e-15)


# the rules each __post_init__ documents: finite and > 0, finite and >= 0, integer >= 1
_RULES = {
    "HuskyParams": (HUSKY, ("track_m", "wheelbase_m", "wheel_radius_m", "mass_kg",
                            "yaw_inertia_kg_m2", "contact_length_m", "contact_width_m"),
                    ("speed_quantum_m_s", "current_quantum_a"), ("wheels_per_motor",)),
    "TrackedParams": (TRACKED, ("track_m", "track_width_m", "track_length_m", "mass_kg",
                                "sprocket_radius_m", "yaw_inertia_kg_m2"),
                      ("cog_height_m", "slip_parameter_n"), ("n_segments", "wheels_per_motor")),
    "AgriMaRoParams": (AGRIMARO, ("wheel_radius_m", "mass_kg", "yaw_inertia_kg_m2",
                                  "steering_rate_rad_s", "contact_length_m", "contact_width_m"),
                       ("steering_dead_band_rad",), ("wheels_per_motor",)),
    "MotorParams": (HUSKY.motor, ("torque_constant_nm_per_a", "gear_ratio", "efficiency",
                                  "speed_time_constant_s", "max_wheel_speed_rad_s"),
                    ("no_load_current_a", "encoder_filter_s", "wheel_inertia_kg_m2"),
                    ("encoder_counts_per_rev",)),
}
_CASES = [(owner, name, value, ok)
          for owner, (_, positive, non_negative, counts) in _RULES.items()
          for name, values in ([(f, (0.0, -1.0, float("nan"), float("inf"), True))
                                for f in positive]
                               + [(f, (-1.0, float("inf"), False)) for f in non_negative]
                               + [(f, (0, 2.0, True)) for f in counts])
          for value, ok in ((v, False) for v in values)]
_CASES += [(owner, name, 0.0, True) for owner, (_, _, non_negative, _) in _RULES.items()
           for name in non_negative]


@pytest.mark.parametrize("owner, name, value, ok", _CASES,
                         ids=[f"{o}.{n}={v!r}" for o, n, v, _ in _CASES])
def test_every_documented_parameter_rule_holds(owner, name, value, ok):
    from dataclasses import replace

    from terrain.errors import ConfigError

    # mutants that dropped the Tracked track_m, yaw inertia or CoG height, the Husky contact
    # width, current quantum or wheels per motor, or AgriMaRo's inertia, patch width or
    # wheels per motor from their checks survived (a 0 m track divides the yaw rate by 0)
    base = _RULES[owner][0]
    if ok:
        assert getattr(replace(base, **{name: value}), name) == value
    else:
        with pytest.raises(ConfigError, match=f"{owner}.{name}"):
            replace(base, **{name: value})


@pytest.mark.parametrize("owner", sorted(_RULES))
def test_every_number_of_a_parameter_set_has_a_rule(owner):
    from dataclasses import fields

    # a numeric field added without a check would take NaN, inf or a negative silently
    base, positive, non_negative, counts = _RULES[owner]
    numeric = {f.name for f in fields(base) if isinstance(getattr(base, f.name), (int, float))}
    assert numeric == set(positive) | set(non_negative) | set(counts)


@pytest.mark.parametrize("vehicle", [HUSKY, TRACKED, AGRIMARO], ids=["husky", "tracked",
                                                                     "agrimaro"])
def test_a_vehicle_without_motor_parameters_is_refused(vehicle):
    from dataclasses import replace

    from terrain.errors import ConfigError

    # AgriMaRo's check_motor dropped survived: a dict of motor numbers was accepted
    with pytest.raises(ConfigError, match=f"{type(vehicle).__name__}.motor"):
        replace(vehicle, motor={"gear_ratio": 1.0})


def test_drive_power_while_braking_is_the_back_emf_times_the_partly_cancelled_current():
    # the docstring said |omega T| / eta plus the no-load loss whatever the signs; braking
    # at 1 rad/s with -5 N m on the Husky the current is 1 - 5 / (78.71 0.044 0.8) = -0.805 A
    # and the power k_t G |omega| |I| = 2.79 W, not 5 / 0.8 + 3.46 = 9.71 W
    m = HUSKY.motor
    current = m.current_from_torque(-5.0, 1.0)
    assert current == pytest.approx(np.tanh(20.0) - 5.0 / (78.71 * 0.044 * 0.8), rel=1e-12)
    assert m.drive_power_w(current, 1.0) == pytest.approx(
        0.044 * 78.71 * abs(current), rel=1e-12)
    assert m.drive_power_w(current, 1.0) == pytest.approx(2.79, abs=0.01)
    assert m.drive_power_w(m.current_from_torque(5.0, 1.0), 1.0) == pytest.approx(
        5.0 / 0.8 + 0.044 * 78.71 * np.tanh(20.0), rel=1e-12)


@pytest.mark.parametrize("v, omega, arm", [
    (np.zeros(3), np.array([0.0, 0.0]), np.array(AGRIMARO.camera_lever_arm_m)),
    (np.zeros(2), np.array([0.0, 0.0, 1.0]), np.array(AGRIMARO.camera_lever_arm_m)),
    (np.zeros(3), np.array([0.0, 0.0, 1.0]), np.array([0.6685, -0.26875])),
])
def test_camera_lever_arm_vectors_must_be_3_vectors(v, omega, arm):
    import warnings

    from terrain.errors import ShapeError
    from terrain.vehicles import camera_to_robot_velocity, robot_to_camera_velocity

    # a 2-entry omega or lever arm was taken as (x, y, 0) by np.cross with only NumPy 2's
    # DeprecationWarning (a planar (0.6685, -0.26875) arm gave the eq. 5.4 answer of a 3-D
    # one by luck); a 2-entry velocity raised the bare broadcast ValueError
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        for f in (robot_to_camera_velocity, camera_to_robot_velocity):
            with pytest.raises(ShapeError, match=r"\(\.\.\., 3\)|\(3,\)"):
                f(v, omega, arm)


def test_t265_vectors_must_be_3_vectors():
    from terrain.errors import ShapeError
    from terrain.vehicles import t265_tracking_to_robot

    # NumPy's bare "matmul: Input operand 1 has a mismatch in its core dimension" before
    with pytest.raises(ShapeError, match="vectors"):
        t265_tracking_to_robot(np.zeros(4))


@pytest.mark.parametrize("field, value", [
    ("wheel_positions_m", (("-0.5075", "0"), (0.5075, 0.0), (0.0, -0.756))),
    ("camera_lever_arm_m", ("0.6685", -0.26875, 0.0)),
    ("camera_lever_arm_m", (b"0.6685", -0.26875, 0.0)),
])
def test_agrimaro_geometry_refuses_text_coordinates(field, value):
    from dataclasses import replace

    from terrain.errors import ConfigError

    # text was converted by np.asarray(dtype=float) and kept as text in the field (every
    # scalar parameter refuses text, config_numbers)
    with pytest.raises(ConfigError, match=field):
        replace(AGRIMARO, **{field: value})


def test_agrimaro_geometry_given_as_arrays_is_stored_as_tuples():
    from dataclasses import replace

    # arrays were kept as given: comparing the parameters raised NumPy's "truth value of an
    # array is ambiguous" and hashing them a TypeError
    v = replace(AGRIMARO, wheel_positions_m=np.array(AGRIMARO.wheel_positions_m),
                camera_lever_arm_m=np.array(AGRIMARO.camera_lever_arm_m))
    assert v == AGRIMARO and hash(v) == hash(AGRIMARO)
    assert v.wheel_positions_m == AGRIMARO.wheel_positions_m
    assert isinstance(v.camera_lever_arm_m, tuple)


def test_inverse_icr_factor_of_single_numbers_is_a_shape_error():
    from terrain.errors import ShapeError

    # 0-d arrays have no sample axis: _origin_slope's x.shape[-1] raised a bare IndexError
    # ("tuple index out of range")
    with pytest.raises(ShapeError, match=r"sample axis.*\(\)"):
        inverse_icr_factor(0.5, 0.4)
    assert inverse_icr_factor(np.array([0.5]), np.array([0.4])) == pytest.approx(0.5 / 0.4)


def test_swerve_kinematics_of_a_skid_steer_are_a_config_error():
    from terrain.errors import ConfigError

    # a vehicle from get_vehicle("husky") raised AttributeError "'HuskyParams' object has
    # no attribute 'positions'"
    with pytest.raises(ConfigError, match="swerve_inverse.*AgriMaRoParams.*HuskyParams"):
        swerve_inverse(np.zeros(3), HUSKY)
    with pytest.raises(ConfigError, match="swerve_forward.*AgriMaRoParams.*TrackedParams"):
        swerve_forward(np.zeros(3), np.zeros(3), TRACKED)
