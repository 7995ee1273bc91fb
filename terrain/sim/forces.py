"""Force model of the simulator: ground-contact forces from state, commands and terrain.

Pure functions, no time stepping (the integrator is :func:`terrain.sim.dynamics.integrate`).
One point of contact per wheel, several per track; for each contact ``i`` with normal load
``N_i`` (static, no load transfer):

* longitudinal force ``N_i [mu(s_i) - f_soil(s_i) tanh(v_long,i / 0.01 m/s)]`` with the SAE
  slip ``s_i`` of the rim speed against the contact's longitudinal velocity
  (:func:`terrain.terramechanics.slip.sae_slip`, floored at
  :data:`SLIP_SPEED_FLOOR_M_S`), the traction curve ``mu`` and the motion resistance
  ``f_soil`` of the terrain (:meth:`terrain.terramechanics.traction.TractionCurve.coefficients`);
* lateral force ``-mu_lat N_i tanh(v_lat,i / 0.02 m/s)``
  (:func:`terrain.terramechanics.resistance.lateral_force_and_slope`: skid-steer turning
  resistance, swerve cornering);
* the ICR expansion ``chi`` (effect ``icr_expansion``) places the *kinematic* longitudinal
  contact lines of a skid-steer at ``chi y_i`` (Mandow et al. 2007), so with pure rolling
  ``yaw_rate = (v_R - v_L) / (chi B)``; forces act at the geometric contacts;
* gravity along the inclined plane (grade resistance, seed 003 eq. 10-11).

:func:`contact_forces` also returns the analytic Jacobian ``dF/dV`` that the linearly implicit
integrator needs.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import NamedTuple

import numpy as np

from terrain.terramechanics.resistance import G_M_S2, lateral_force_and_slope
from terrain.terramechanics.slip import sae_slip_and_velocity_slope
from terrain.vehicles.common import ContactGeometry

#: Lateral regularisation speed of the contact friction, m/s (stands for the lateral
#: compliance of tyre and soil).
SLIDE_SPEED_M_S = 0.02
#: Low-speed regularisation of the longitudinal slip, m/s: the SAE slip denominator
#: max(|omega r|, |v|) is floored at this speed, so near standstill the slip is linear in the
#: speed difference instead of jumping between -1 and 1 (without it a wheel held at zero
#: speed while the body creeps makes the contact force chatter; found by the audit, see
#: docs/audit_report.md). Same order as the lateral regularisation speed above.
SLIP_SPEED_FLOOR_M_S = 0.02
#: Regularisation speed of the sign of the soil resistance, m/s.
SOIL_SPEED_M_S = 0.01
#: Regularisation speed of the sign of the torque-only rolling loss, m/s.
HYSTERESIS_SPEED_M_S = 0.05


@dataclass(frozen=True)
class ContactLayout:
    """Contacts of a vehicle on the ground plane (constant during a run; c contacts).

    Parameters
    ----------
    x_m : ndarray, shape (c,)
        Longitudinal contact positions in the body frame, m.
    y_m : ndarray, shape (c,)
        Lateral contact positions (where the forces act), m.
    y_kinematic_m : ndarray, shape (c,)
        Lateral positions of the kinematic contact lines, m (``chi y`` for a skid-steer with
        the ICR expansion ``chi``, ``y`` otherwise).
    motor_of : ndarray of int, shape (c,)
        Motor driving each contact.
    n_motors : int
        Number of motors m.
    wheel_radius_m : float
        Rolling radius of wheels (sprocket radius of tracks), m.
    normal_load_n : ndarray, shape (c,)
        Static normal load of each contact, N.
    steered : bool
        Whether the contacts steer (swerve drive).
    """

    x_m: np.ndarray
    y_m: np.ndarray
    y_kinematic_m: np.ndarray
    motor_of: np.ndarray
    n_motors: int
    wheel_radius_m: float
    normal_load_n: np.ndarray
    steered: bool


def contact_layout(geometry: ContactGeometry, mass_kg: float, slope_rad: float,
                   chi: float) -> ContactLayout:
    """Contact layout of a vehicle on a plane of inclination ``slope_rad``.

    Parameters
    ----------
    geometry : ContactGeometry
        Contact positions, load shares and motor map of the vehicle.
    mass_kg : float
        Vehicle mass, kg.
    slope_rad : float
        Inclination of the plane, rad (normal loads scale with its cosine).
    chi : float
        ICR expansion (>= 1; ignored for steered vehicles).

    Returns
    -------
    ContactLayout
    """
    pos = geometry.positions_m
    x_c, y_c = pos[:, 0].copy(), pos[:, 1].copy()
    return ContactLayout(
        x_m=x_c, y_m=y_c, y_kinematic_m=y_c * (1.0 if geometry.steered else chi),
        motor_of=geometry.motor_of_contact, n_motors=geometry.n_motors,
        wheel_radius_m=geometry.wheel_radius_m,
        normal_load_n=geometry.load_share * mass_kg * G_M_S2 * np.cos(slope_rad),
        steered=geometry.steered)


class VelocityMaps(NamedTuple):
    """Linear maps of the body twist ``V = (v_x, v_y, yaw_rate)`` onto contact velocities.

    Attributes
    ----------
    long_kinematic : ndarray, shape (c, 3)
        ``V -> v_long`` at the kinematic contact lines (what the slip sees).
    long_force : ndarray, shape (c, 3)
        ``V -> v_long`` at the geometric contacts (transpose: where the forces act).
    lateral : ndarray, shape (c, 3)
        ``V -> v_lat`` at the geometric contacts.
    """

    long_kinematic: np.ndarray
    long_force: np.ndarray
    lateral: np.ndarray


def velocity_maps(layout: ContactLayout, cos_delta: np.ndarray, sin_delta: np.ndarray
                  ) -> VelocityMaps:
    """Contact velocity maps for the current steering angles.

    Parameters
    ----------
    layout : ContactLayout
        Contacts.
    cos_delta, sin_delta : ndarray, shape (c,)
        Cosine and sine of each contact's steering angle (1 and 0 for fixed wheels).

    Returns
    -------
    VelocityMaps
    """
    x_c, y_c = layout.x_m, layout.y_m
    cd, sd = cos_delta, sin_delta
    maps = np.empty((3, len(cd), 3))
    maps[0, :, 0] = cd
    maps[0, :, 1] = sd
    maps[0, :, 2] = -layout.y_kinematic_m * cd + x_c * sd
    maps[1, :, :2] = maps[0, :, :2]
    maps[1, :, 2] = -y_c * cd + x_c * sd
    maps[2, :, 0] = -sd
    maps[2, :, 1] = cd
    maps[2, :, 2] = y_c * sd + x_c * cd
    return VelocityMaps(maps[0], maps[1], maps[2])


class ContactForces(NamedTuple):
    """Ground-contact forces on the body and what the integrator needs of them.

    Attributes
    ----------
    force : ndarray, shape (3,)
        ``(F_x, F_y, M_z)`` in the body frame, N, N, N m (contacts only).
    jacobian : ndarray, shape (3, 3)
        ``d force / d V``, the analytic Jacobian (secant slopes where the tangent would let
        a Newton step overshoot).
    mu : ndarray, shape (c,)
        Traction coefficient of each contact (signed).
    rim_speed_m_s : ndarray, shape (c,)
        ``omega r`` of each contact, m/s.
    """

    force: np.ndarray
    jacobian: np.ndarray
    mu: np.ndarray
    rim_speed_m_s: np.ndarray


def contact_forces(layout: ContactLayout, maps: VelocityMaps, terrain, twist: np.ndarray,
                   omega: np.ndarray) -> ContactForces:
    """Contact forces of all wheels/tracks and their Jacobian (the force model).

    Parameters
    ----------
    layout : ContactLayout
        Contacts.
    maps : VelocityMaps
        Contact velocity maps for the current steering (:func:`velocity_maps`).
    terrain : TerrainParams
        Terrain under the vehicle (traction curve, resistances, lateral friction).
    twist : ndarray, shape (3,)
        Body twist ``(v_x, v_y, yaw_rate)``, m/s, m/s, rad/s.
    omega : ndarray, shape (m,)
        Motor (wheel) speeds, rad/s.

    Returns
    -------
    ContactForces
    """
    normal = layout.normal_load_n
    a_mat, a_force, b_mat = maps
    v_long = a_mat @ twist
    v_lat = b_mat @ twist
    wr = omega[layout.motor_of] * layout.wheel_radius_m
    slip, ds_dv = sae_slip_and_velocity_slope(wr, v_long, SLIP_SPEED_FLOOR_M_S)
    abs_s = np.abs(slip)
    sign_s = np.sign(slip)
    coef = terrain.curve.coefficients(abs_s, terrain.soil_resistance)
    mu = sign_s * coef.mu
    dmu = coef.dmu_ds
    f_soil = coef.resistance
    th_s = np.tanh(v_long / SOIL_SPEED_M_S)
    f_long = normal * (mu - f_soil * th_s)
    # secant slope mu(s)/s where it exceeds the tangent: keeps the Newton step from
    # overshooting past the traction peak (no limit cycles on stiff, peaked curves)
    secant = np.where(abs_s > 1e-6, mu / np.where(abs_s > 1e-6, slip, 1.0), dmu)
    dmu = np.maximum(dmu, secant)
    k_long = normal * (dmu * ds_dv - f_soil * (1.0 - th_s * th_s) / SOIL_SPEED_M_S)
    k_long = k_long - normal * th_s * coef.dresistance_ds * sign_s * ds_dv
    f_lat, k_lat = lateral_force_and_slope(terrain.lateral_friction, normal, v_lat,
                                           SLIDE_SPEED_M_S)
    force = a_force.T @ f_long + b_mat.T @ f_lat
    jac = (a_force.T * k_long) @ a_mat + (b_mat.T * k_lat) @ b_mat
    return ContactForces(force, jac, mu, wr)


def gravity_force(mass_kg: float, slope_rad: float, yaw_rad: float) -> np.ndarray:
    """Gravity along an inclined plane rising along world +x, in the body frame.

    Grade resistance ``m g sin(slope)`` (seed 003 eq. 10-11) resolved on the body axes.

    Parameters
    ----------
    mass_kg : float
        Vehicle mass, kg.
    slope_rad : float
        Inclination of the plane, rad.
    yaw_rad : float
        Heading of the body on the plane, rad (0 = facing uphill).

    Returns
    -------
    ndarray, shape (3,)
        ``(F_x, F_y, M_z)``, N, N, N m.
    """
    g_plane = G_M_S2 * np.sin(slope_rad)
    cy, sy = np.cos(yaw_rad), np.sin(yaw_rad)
    return np.array([-mass_kg * g_plane * cy, mass_kg * g_plane * sy, 0.0])


def contact_torque_nm(layout: ContactLayout, terrain, mu: np.ndarray,
                      rim_speed_m_s: np.ndarray) -> np.ndarray:
    """Torque each contact asks of its motor: traction plus torque-only rolling loss.

    ``r N_i (mu_i + h tanh(omega r / 0.05 m/s))`` with the terrain's hysteresis ``h``
    (calibrated to the measured Husky currents, :mod:`terrain.terramechanics.calibration`).

    Parameters
    ----------
    layout : ContactLayout
        Contacts.
    terrain : TerrainParams
        Terrain under the vehicle.
    mu : ndarray, shape (c,)
        Signed traction coefficients (:attr:`ContactForces.mu`).
    rim_speed_m_s : ndarray, shape (c,)
        Rim speeds, m/s.

    Returns
    -------
    ndarray, shape (c,)
        N m.
    """
    return layout.wheel_radius_m * layout.normal_load_n * (
        mu + terrain.hysteresis * np.tanh(rim_speed_m_s / HYSTERESIS_SPEED_M_S))
