"""The vehicle kinematics that the EKF kernels inline (terrain.vehicles, register_jitable)."""

import numpy as np
import pytest

from terrain.vehicles import (AGRIMARO, HUSKY, body_rates, point_velocity, rim_speed_row,
                              side_speeds, wheel_rim_speed)
from terrain.vehicles.icr import chi_from_truth
from terrain.vehicles.swerve import h_matrix


def test_point_velocity_is_the_rigid_body_map_of_eq_2_2():
    twist = np.array([0.4, 1.2, -0.3])                           # yaw_rate, v_x, v_y
    p = AGRIMARO.positions
    vx, vy = point_velocity(twist[1], twist[2], twist[0], p[:, 0], p[:, 1])
    stacked = h_matrix(p) @ twist
    assert np.allclose(np.column_stack([vx, vy]).ravel(), stacked)
    # a point on the yaw axis moves with the body origin
    assert point_velocity(1.0, 2.0, 5.0, 0.0, 0.0) == (1.0, 2.0)


def test_rim_speed_row_partials_match_finite_differences():
    args = np.array([0.8, -0.2, 0.5, 0.3, -0.4, 0.25])      # v_bx, v_by, r, x, y, delta
    value, *partials = rim_speed_row(*args)
    assert value == pytest.approx(wheel_rim_speed(*args))
    eps = 1e-7
    for k, col in zip(partials, (0, 1, 2, 5)):
        hi, lo = args.copy(), args.copy()
        hi[col] += eps
        lo[col] -= eps
        fd = (rim_speed_row(*hi)[0] - rim_speed_row(*lo)[0]) / (2 * eps)
        assert k == pytest.approx(fd, abs=1e-6)


def test_side_speeds_and_body_rates_invert_each_other():
    v, w = np.array([0.5, -0.2, 1.0]), np.array([0.3, 1.1, -0.7])
    vl, vr = side_speeds(v, w, HUSKY.track_m, 1.4)
    v2, w2 = body_rates(vl, vr, HUSKY.track_m, 1.4)
    assert np.allclose(v2, v) and np.allclose(w2, w)
    assert np.allclose(vr - vl, 1.4 * HUSKY.track_m * w)     # ICR expansion widens the track


def test_chi_from_truth_recovers_a_planted_expansion():
    rng = np.random.default_rng(0)
    w = rng.uniform(-1.0, 1.0, 500)
    v = rng.uniform(0.0, 1.0, 500)
    vl, vr = side_speeds(v, w, HUSKY.track_m, 1.7)
    assert chi_from_truth(vl, vr, w, HUSKY.track_m) == pytest.approx(1.7)
    assert np.isnan(chi_from_truth(vl, vr, np.zeros(500), HUSKY.track_m))
