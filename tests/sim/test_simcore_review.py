"""Review of the simulator core: the attitude the truth stream and the IMU report agrees with
the gravity the dynamics apply on the inclined plane."""

from __future__ import annotations

import numpy as np
import pytest

from terrain.sim.dynamics import slope_attitude
from terrain.sim.forces import gravity_force, specific_force_m_s2
from terrain.sim.sensors import gravity_specific_force


def test_facing_along_the_contour_the_uphill_side_is_the_right_one():
    # the plane rises along world +x; facing world +y (yaw pi/2) the right side (body -y)
    # points to world +x, uphill: right side up is a negative roll, and no pitch
    slope = np.radians(15.0)
    pitch, roll = slope_attitude(slope, 0.5 * np.pi)
    assert pitch == pytest.approx(0.0, abs=1e-12)
    assert roll == pytest.approx(-slope, rel=1e-12)
    pitch, roll = slope_attitude(slope, -0.5 * np.pi)
    assert roll == pytest.approx(slope, rel=1e-12)


@pytest.mark.parametrize("yaw", [0.0, 0.4, 1.2, 0.5 * np.pi, 2.5, np.pi, -0.7, -2.0])
def test_the_imu_gravity_is_the_specific_force_of_the_dynamics_gravity(yaw):
    # what the IMU adds for gravity at the reported pitch and roll is what the dynamics'
    # gravity along the plane gives as specific force at rest, -F_g / m, on both axes
    slope, mass = np.radians(15.0), 50.0
    pitch, roll = slope_attitude(slope, yaw)
    g_x, g_y, g_z = gravity_specific_force(np.array([pitch]), np.array([roll]))
    f = specific_force_m_s2(np.zeros(2), gravity_force(mass, slope, yaw), mass)
    np.testing.assert_allclose([g_x[0], g_y[0]], f, atol=1e-12)
    assert g_z[0] == pytest.approx(9.80665 * np.cos(slope), rel=1e-12)


def test_the_pose_advances_along_the_mid_step_heading_of_the_twist():
    # a steady left turn: each step moves the pose by dt times the stored body velocity
    # rotated to the heading halfway through the step (the midpoint rule), so the chord's
    # direction sits halfway between the yaws before and after the step (off by r dt / 2 =
    # 3 mrad at 0.6 rad/s, 100 Hz, with the heading at the start of the step)
    from terrain.sim.dynamics import integrate
    from terrain.terramechanics.catalogue import get_terrain
    from terrain.vehicles import HUSKY

    t = np.arange(0.0, 3.0, 0.01)
    cmd = np.column_stack([np.full_like(t, 0.8), np.zeros_like(t), np.full_like(t, 0.6)])
    p = integrate(HUSKY, HUSKY.contact_geometry(), (get_terrain("ASPHALT"),), 1e9, t, cmd,
                  0.0, 1.0)
    step = np.diff(p.pose[:, :2], axis=0)
    v = p.twist[1:, :2]
    mid = 0.5 * (p.pose[:-1, 2] + p.pose[1:, 2])
    world = np.column_stack([v[:, 0] * np.cos(mid) - v[:, 1] * np.sin(mid),
                             v[:, 0] * np.sin(mid) + v[:, 1] * np.cos(mid)])
    assert p.twist[-1, 2] > 0.3                        # a turn under way
    np.testing.assert_allclose(step, 0.01 * world, rtol=0, atol=1e-12)


def test_the_motor_torque_carries_the_wheel_inertia_times_the_wheel_acceleration():
    # the wheel speeds follow the command through the motor lag whatever the wheels'
    # inertia, so two runs that differ only in it move alike and their torques differ by
    # the added inertia times the wheel acceleration: more torque while the wheels spin up,
    # less while they slow down
    from dataclasses import replace

    from terrain.sim.dynamics import integrate
    from terrain.terramechanics.catalogue import get_terrain
    from terrain.vehicles import HUSKY

    t = np.arange(0.0, 4.0, 0.01)
    v = np.where(t < 2.0, np.minimum(t, 1.0), np.maximum(3.0 - t, 0.0))
    cmd = np.column_stack([v, np.zeros_like(t), np.zeros_like(t)])
    heavy = replace(HUSKY, motor=replace(HUSKY.motor, wheel_inertia_kg_m2=(
        HUSKY.motor.wheel_inertia_kg_m2 + 0.5)))
    runs = [integrate(veh, HUSKY.contact_geometry(), (get_terrain("ASPHALT"),), 1e9, t, cmd,
                      0.0, 1.0) for veh in (HUSKY, heavy)]
    np.testing.assert_array_equal(runs[0].omega, runs[1].omega)
    dw = np.diff(runs[0].omega, axis=0, prepend=np.zeros((1, 2))) / 0.01
    extra = 0.5 * HUSKY.wheels_per_motor * dw
    assert extra.max() > 0.5 and extra.min() < -0.5          # spin-up and slow-down
    np.testing.assert_allclose(runs[1].torque - runs[0].torque, extra, rtol=1e-9, atol=1e-9)


def test_the_reported_current_of_physics_v2_in_each_quadrant():
    # v2 reports I_0 + T / k while the motor drives, only I_0 while it brakes (the torque
    # against the speed) and the holding torque |T| / k at a standstill; v1 reports |I|
    from terrain.sim.forces import reported_current_a
    from terrain.vehicles import HUSKY

    m = HUSKY.motor
    k = m.gear_ratio * m.torque_constant_nm_per_a * m.efficiency
    torque = np.array([4.0, -4.0, -4.0, 4.0, 4.0, -4.0])
    omega = np.array([20.0, -20.0, 20.0, -20.0, 0.0, 0.0])
    got = reported_current_a(m, torque, omega, "v2")
    i0 = m.no_load_current_a * np.tanh(20.0 / 0.05)
    np.testing.assert_allclose(got, [i0 + 4 / k, i0 + 4 / k, i0, i0, 4 / k, 4 / k],
                               rtol=1e-12)
    np.testing.assert_allclose(reported_current_a(m, torque, omega, "v1"),
                               np.abs(m.current_from_torque(torque, omega)), rtol=1e-12)


def test_the_motor_torque_of_a_ramp_does_not_depend_on_the_physics_step():
    # the motors pay for the traction the implicit step gave the body (the linearised
    # coefficient over the step): a Husky ramping at 0.5 m/s^2 on ASPHALT needs the same
    # torque at 100 Hz and at 1 kHz physics, 4.92 N m per side (the coefficient at the start
    # of the step, with the new wheel speed and the old body speed, gave 14.3 N m at 100 Hz
    # and 5.96 at 1 kHz)
    from terrain.sim.dynamics import integrate
    from terrain.terramechanics.catalogue import get_terrain
    from terrain.vehicles import HUSKY

    torque = []
    for dt in (0.01, 0.001):
        t = np.arange(0.0, 1.5 + 0.5 * dt, dt)
        cmd = np.column_stack([0.5 * t, np.zeros_like(t), np.zeros_like(t)])
        p = integrate(HUSKY, HUSKY.contact_geometry(), (get_terrain("ASPHALT"),), 1e9, t,
                      cmd, 0.0, 1.0)
        torque.append(p.torque[(t > 1.0) & (t <= 1.5)].mean())
    assert torque[0] == pytest.approx(torque[1], rel=0.1)
