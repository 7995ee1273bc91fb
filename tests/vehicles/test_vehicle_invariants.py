"""Vehicle kinematics and contact geometry against their sources' invariants.

The pose rates of seed 000 eq. 1, the side of each skid-steer contact, the static
equilibrium of the static loads (the contacts carry the weight at the centre of gravity),
the steering rate of seed 001 ch. 2.2 and the T265 IMU axes of ch. 5.2.3.
"""

from __future__ import annotations

import numpy as np
import pytest

from terrain.vehicles import (AGRIMARO, HUSKY, TRACKED, TrackedParams, get_vehicle,
                              skid_steer_pose_rates)
from terrain.vehicles.swerve import R_ROBOT_FROM_T265_IMU


def test_pose_rates_are_the_unicycle_of_seed_000_eq_1():
    # x_dot = V cos(theta), y_dot = V sin(theta), theta_dot = Omega
    rates = skid_steer_pose_rates(np.array([0.0, np.pi / 2, np.pi / 6]),
                                  np.array([2.0, 2.0, 1.0]), np.array([0.1, -0.2, 0.3]))
    assert np.allclose(rates, [[2.0, 0.0, 0.1], [0.0, 2.0, -0.2],
                               [np.sqrt(3) / 2, 0.5, 0.3]], atol=1e-12)


@pytest.mark.parametrize("vehicle", [HUSKY, TRACKED, TrackedParams(n_segments=4)],
                         ids=["husky", "tracked", "tracked-4"])
def test_each_skid_steer_contact_is_driven_by_the_motor_of_its_side(vehicle):
    # body frame y left (REP-103): contacts with y > 0 belong to the left motor
    g = vehicle.contact_geometry()
    sides = np.array(g.motor_names)[g.motor_of_contact]
    assert list(sides) == ["left" if y > 0 else "right" for y in g.positions_m[:, 1]]
    assert np.allclose(np.abs(g.positions_m[:, 1]), vehicle.track_m / 2.0)


@pytest.mark.parametrize("n", [1, 2, 5])
def test_track_contacts_are_the_centres_of_equal_pieces_of_the_track(n):
    v = TrackedParams(n_segments=n)
    xs = v.contact_geometry().positions_m[:n, 0]
    piece = v.track_length_m / n
    assert np.allclose(xs, -v.track_length_m / 2.0 + piece * (np.arange(n) + 0.5))


@pytest.mark.parametrize("name", ["husky", "tracked", "agrimaro"])
def test_static_loads_carry_the_weight_at_the_centre_of_gravity(name):
    # static equilibrium: sum N_i = W and sum N_i d_i = W d_cog (moments about the origin);
    # the skid-steers have their CoG at the reference point, AgriMaRo at cog_m
    v = get_vehicle(name)
    g = v.contact_geometry()
    cog = getattr(v, "cog_m", np.zeros(2))
    assert g.load_share.sum() == pytest.approx(1.0)
    assert np.allclose(g.load_share @ g.positions_m, cog, atol=1e-12)
    if name == "agrimaro":      # the centroid of d_1..d_3 of seed 001 ch. 7.2
        assert np.allclose(cog, [0.0, -0.252])


def test_agrimaro_steering_rate_is_20_rpm():
    # seed 001 ch. 2.2: steering speed 20 rpm
    assert AGRIMARO.steering_rate_rad_s == pytest.approx(20.0 * 2.0 * np.pi / 60.0)
    assert AGRIMARO.steering_rate_rad_s == pytest.approx(2.0944, abs=1e-4)


def test_t265_imu_axes_map_to_the_robot_axes_by_a_proper_rotation():
    # T265 IMU frame: x left, y up, z forward; robot: x forward, y left, z up
    r = R_ROBOT_FROM_T265_IMU
    assert np.allclose(r @ r.T, np.eye(3)) and np.linalg.det(r) == pytest.approx(1.0)
    assert np.allclose(r @ [0.0, 0.0, 1.0], [1.0, 0.0, 0.0])     # forward
    assert np.allclose(r @ [1.0, 0.0, 0.0], [0.0, 1.0, 0.0])     # left
    assert np.allclose(r @ [0.0, 1.0, 0.0], [0.0, 0.0, 1.0])     # up
