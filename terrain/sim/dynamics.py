"""Planar rigid-body dynamics of a vehicle on terrain (fixed step, linearly implicit Euler).

State: pose ``(x, y, yaw)`` on the ground plane, body twist ``V = (v_x, v_y, yaw_rate)``,
motor speeds ``omega`` (rad/s) and, for swerve drives, steering angles ``delta``.

Ground contact (one point per wheel, several per track):

* longitudinal force ``N_i [mu(s_i) - f_soil(s_i) sign(v_long,i)]`` with the SAE slip ``s_i``
  of the rim speed against the contact's longitudinal velocity (traction curve of
  :mod:`terrain.terramechanics`);
* lateral force ``-mu_lat N_i tanh(v_lat,i / 0.02 m/s)`` (skid-steer turning resistance, swerve
  cornering; a vehicle whose longitudinal forces cannot beat it digs in and stops turning while
  its wheels spin);
* the ICR expansion ``chi`` (effect ``icr_expansion``) places the longitudinal contact lines of
  a skid-steer at ``chi y_i`` (Mandow et al. 2007), so with pure rolling
  ``yaw_rate = (v_R - v_L) / (chi B)``;
* gravity along the inclined plane (grade resistance, seed 003 eq. 10-11).

The stiff contact forces are integrated with one Newton step per time step,
``(M - dt J) dV = dt F(V)``, ``J = dF/dV`` analytic, which is stable at 100 Hz.

Simplifications (stated): static normal loads (no load transfer), mass concentrated at the
body origin, speed-controlled motors as first-order lags with speed limits.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from terrain.terramechanics.resistance import G_M_S2, soil_resistance_coefficient
from terrain.terramechanics.traction import BrixiusCurve, traction_curve_and_slope
from terrain.vehicles.common import ContactGeometry
from terrain.vehicles.swerve import swerve_inverse
from terrain.vehicles.skid_steer import skid_steer_inverse

SLIDE_SPEED_M_S = 0.02
#: Low-speed regularisation of the longitudinal slip, m/s: the SAE slip denominator
#: max(|omega r|, |v|) is floored at this speed, so near standstill the slip is linear in the
#: speed difference instead of jumping between -1 and 1 (without it a wheel held at zero
#: speed while the body creeps makes the contact force chatter; found by the audit, see
#: docs/audit_report.md). Same order as the lateral regularisation speed above.
SLIP_SPEED_FLOOR_M_S = 0.02
SOIL_SPEED_M_S = 0.01


@dataclass(frozen=True)
class PhysicsResult:
    """Ground truth at every physics step (n steps, c contacts, m motors).

    Attributes
    ----------
    t_s : (n,) s
    pose : (n, 3) x, y (m, ground plane), yaw (rad, unwrapped)
    twist : (n, 3) v_x, v_y (m/s), yaw_rate (rad/s), body frame
    accel_body : (n, 2) body-frame kinematic acceleration (dV/dt + r x V), m/s^2
    omega : (n, m) true motor/wheel speeds, rad/s
    omega_cmd : (n, m) commanded wheel speeds, rad/s
    slip_motor : (n, m) mean SAE slip of the contacts of each motor
    delta : (n, m) steering angles (zeros for skid-steer), rad
    torque : (n, m) wheel torque of each motor, N m
    pitch, roll : (n,) nose-up and right-side-down inclination, rad
    terrain_index : (n,) index into ``terrain_names``
    terrain_names : tuple of str
    """

    t_s: np.ndarray
    pose: np.ndarray
    twist: np.ndarray
    accel_body: np.ndarray
    omega: np.ndarray
    omega_cmd: np.ndarray
    slip_motor: np.ndarray
    delta: np.ndarray
    torque: np.ndarray
    pitch: np.ndarray
    roll: np.ndarray
    terrain_index: np.ndarray
    terrain_names: tuple[str, ...]


def wheel_commands(vehicle, geometry: ContactGeometry, twist_cmd: np.ndarray
                   ) -> tuple[np.ndarray, np.ndarray]:
    """Wheel speed and steering commands from the commanded twist (inverse kinematics).

    Parameters
    ----------
    vehicle : AgriMaRoParams or HuskyParams or TrackedParams
    geometry : ContactGeometry
    twist_cmd : ndarray, shape (n, 3)
        ``(v_x, v_y, yaw_rate)``.

    Returns
    -------
    omega_cmd : ndarray, shape (n, n_motors), rad/s (clipped to the speed limit)
    delta_cmd : ndarray, shape (n, n_motors), rad (zeros for skid-steer)
    """
    n = len(twist_cmd)
    wmax = vehicle.motor.max_wheel_speed_rad_s
    if geometry.steered:
        thesis_twist = twist_cmd[:, [2, 0, 1]]          # seed 001 order [yaw_rate, v_x, v_y]
        delta = np.zeros((n, 3))
        omega = np.zeros((n, 3))
        prev = np.zeros(3)
        # sequential so that each unit keeps the solution closest to its previous angle
        for i in range(n):
            d, w = swerve_inverse(thesis_twist[i], vehicle, prev, min_speed_m_s=1e-3)
            delta[i], omega[i] = d, w
            prev = d
        return np.clip(omega, -wmax, wmax), delta
    v_l, v_r = skid_steer_inverse(twist_cmd[:, 0], twist_cmd[:, 2], vehicle.track_m)
    omega = np.column_stack([v_l, v_r]) / geometry.wheel_radius_m
    return np.clip(omega, -wmax, wmax), np.zeros((n, 2))


def integrate(vehicle, geometry: ContactGeometry, terrains: tuple, segment_length_m: float,
              t_s: np.ndarray, twist_cmd: np.ndarray, slope_rad: float, chi: float,
              steer_offset_rad: np.ndarray | None = None) -> PhysicsResult:
    """Integrate the vehicle dynamics over the command sequence.

    Parameters
    ----------
    vehicle : AgriMaRoParams or HuskyParams or TrackedParams
    geometry : ContactGeometry
    terrains : tuple of TerrainParams
        Terrain sequence along the path; the vehicle changes terrain every
        ``segment_length_m`` of travelled distance, cycling through the tuple.
    segment_length_m : float
    t_s : ndarray, shape (n,)
        Uniform time grid, s.
    twist_cmd : ndarray, shape (n, 3)
    slope_rad : float
        Plane inclination (rises along world +x), rad.
    chi : float
        ICR expansion (skid-steer only; 1 = off).
    steer_offset_rad : ndarray, shape (n_motors,), optional
        Constant steering error inside the dead band (swerve only).

    Returns
    -------
    PhysicsResult
    """
    dt = float(t_s[1] - t_s[0])
    n = len(t_s)
    nm = geometry.n_motors
    pos = geometry.positions_m
    x_c, y_c = pos[:, 0].copy(), pos[:, 1].copy()
    y_long = y_c * (1.0 if geometry.steered else chi)
    motor_of = geometry.motor_of_contact
    r_w = geometry.wheel_radius_m
    mass = vehicle.mass_kg
    iz = vehicle.yaw_inertia_kg_m2
    m_diag = np.array([mass, mass, iz])
    normal = geometry.load_share * mass * G_M_S2 * np.cos(slope_rad)
    motor = vehicle.motor
    alpha_m = min(1.0, dt / motor.speed_time_constant_s)
    counts = np.bincount(motor_of, minlength=nm).astype(float)
    steer_rate = getattr(vehicle, "steering_rate_rad_s", 0.0) * dt

    omega_cmd, delta_cmd = wheel_commands(vehicle, geometry, twist_cmd)
    if steer_offset_rad is not None:
        delta_cmd = delta_cmd + steer_offset_rad

    pose_out = np.zeros((n, 3))
    twist_out = np.zeros((n, 3))
    acc_out = np.zeros((n, 2))
    omega_out = np.zeros((n, nm))
    slip_out = np.zeros((n, nm))
    delta_out = np.zeros((n, nm))
    torque_out = np.zeros((n, nm))
    terr_out = np.zeros(n, dtype=np.int64)

    pose = np.zeros(3)
    vel = np.zeros(3)
    omega = np.zeros(nm)
    delta = delta_cmd[0].copy()
    dist = 0.0
    sin_a, g_plane = np.sin(slope_rad), G_M_S2 * np.sin(slope_rad)
    n_terr = len(terrains)
    for k in range(n):
        ti = int(dist // segment_length_m) % n_terr
        ter = terrains[ti]
        # actuators: steering (rate-limited), speed loop (first-order lag)
        if geometry.steered:
            step = (delta_cmd[k] - delta + np.pi) % (2 * np.pi) - np.pi
            delta = delta + np.clip(step, -steer_rate, steer_rate)
        omega_prev = omega
        omega = omega + alpha_m * (omega_cmd[k] - omega)
        dw = (omega - omega_prev) / dt
        d_c = delta[motor_of] if geometry.steered else None
        if d_c is None:
            cd, sd = np.ones_like(x_c), np.zeros_like(x_c)
        else:
            cd, sd = np.cos(d_c), np.sin(d_c)
        # linear maps of V onto contact longitudinal / lateral velocities
        a_mat = np.column_stack([cd, sd, -y_long * cd + x_c * sd])
        # forces act at the geometric contacts; chi only moves the kinematic contact lines
        a_force = np.column_stack([cd, sd, -y_c * cd + x_c * sd])
        b_mat = np.column_stack([-sd, cd, y_c * sd + x_c * cd])
        v_long = a_mat @ vel
        v_lat = b_mat @ vel
        wr = omega[motor_of] * r_w
        den = np.maximum(np.maximum(np.abs(wr), np.abs(v_long)), SLIP_SPEED_FLOOR_M_S)
        slip = np.clip((wr - v_long) / den, -1.0, 1.0)
        body_dominant = np.abs(v_long) >= np.maximum(np.abs(wr), SLIP_SPEED_FLOOR_M_S)
        ds_dv = np.where(body_dominant,
                         -wr * np.sign(v_long) / np.maximum(v_long * v_long, 1e-6), -1.0 / den)
        ds_dv = np.where(np.abs((wr - v_long) / den) >= 1.0, 0.0, ds_dv)
        mu, dmu = traction_curve_and_slope(ter.curve, slip)
        f_soil = soil_resistance_coefficient(ter, slip)
        th_s = np.tanh(v_long / SOIL_SPEED_M_S)
        f_long = normal * (mu - f_soil * th_s)
        # secant slope mu(s)/s where it exceeds the tangent: keeps the Newton step from
        # overshooting past the traction peak (no limit cycles on stiff, peaked curves)
        abs_s = np.abs(slip)
        secant = np.where(abs_s > 1e-6, mu / np.where(abs_s > 1e-6, slip, 1.0), dmu)
        dmu = np.maximum(dmu, secant)
        k_long = normal * (dmu * ds_dv - f_soil * (1.0 - th_s * th_s) / SOIL_SPEED_M_S)
        if isinstance(ter.curve, BrixiusCurve):
            k_long = k_long - normal * th_s * 0.5 / np.sqrt(ter.curve.mobility_number) * np.sign(
                slip) * ds_dv
        th_l = np.tanh(v_lat / SLIDE_SPEED_M_S)
        f_lat = -ter.lateral_friction * normal * th_l
        x_l = v_lat / SLIDE_SPEED_M_S
        sec_l = np.where(np.abs(x_l) > 1e-6, th_l / np.where(np.abs(x_l) > 1e-6, x_l, 1.0), 1.0)
        k_lat = -ter.lateral_friction * normal * sec_l / SLIDE_SPEED_M_S
        cy, sy = np.cos(pose[2]), np.sin(pose[2])
        gravity = np.array([-mass * g_plane * cy, mass * g_plane * sy, 0.0])
        force = a_force.T @ f_long + b_mat.T @ f_lat + gravity
        jac = (a_force.T * k_long) @ a_mat + (b_mat.T * k_lat) @ b_mat
        # Coriolis terms of the body-frame equations: m (dv_x/dt - r v_y) = F_x ...
        force[0] += mass * vel[2] * vel[1]
        force[1] -= mass * vel[2] * vel[0]
        dv = np.linalg.solve(np.diag(m_diag) - dt * jac, dt * force)
        vel_new = vel + dv
        acc_out[k] = [(vel_new[0] - vel[0]) / dt - vel[2] * vel[1],
                      (vel_new[1] - vel[1]) / dt + vel[2] * vel[0]]
        vel = vel_new
        # pose on the plane
        yaw_mid = pose[2] + 0.5 * dt * vel[2]
        cm, sm = np.cos(yaw_mid), np.sin(yaw_mid)
        pose = pose + dt * np.array([vel[0] * cm - vel[1] * sm, vel[0] * sm + vel[1] * cm,
                                     vel[2]])
        dist += dt * float(np.hypot(vel[0], vel[1]))
        # motor torque: traction plus torque-only hysteresis, plus wheel inertia
        t_contact = r_w * normal * (mu + ter.hysteresis * np.tanh(wr / 0.05))
        torque = np.bincount(motor_of, weights=t_contact, minlength=nm) + (
            motor.wheel_inertia_kg_m2 * counts * dw)
        pose_out[k] = pose
        twist_out[k] = vel
        omega_out[k] = omega
        # slip reported consistently with the stored (end-of-step) velocity
        v_long_new = a_mat @ vel
        den_new = np.maximum(np.maximum(np.abs(wr), np.abs(v_long_new)), SLIP_SPEED_FLOOR_M_S)
        slip_new = np.clip((wr - v_long_new) / den_new, -1.0, 1.0)
        slip_out[k] = np.bincount(motor_of, weights=slip_new, minlength=nm) / counts
        delta_out[k] = delta if geometry.steered else 0.0
        torque_out[k] = torque
        terr_out[k] = ti
    yaw = pose_out[:, 2]
    pitch = slope_rad * np.cos(yaw) if slope_rad else np.zeros(n)
    roll = -slope_rad * np.sin(yaw) if slope_rad else np.zeros(n)
    del sin_a
    return PhysicsResult(t_s=t_s, pose=pose_out, twist=twist_out, accel_body=acc_out,
                         omega=omega_out, omega_cmd=omega_cmd, slip_motor=slip_out,
                         delta=delta_out, torque=torque_out, pitch=pitch, roll=roll,
                         terrain_index=terr_out,
                         terrain_names=tuple(t.name for t in terrains))
