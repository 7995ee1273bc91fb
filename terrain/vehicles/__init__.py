"""Vehicle geometry and kinematics: pure functions over frozen, cited parameter dataclasses.

Vehicles
--------
``agrimaro``
    Three-wheel swerve-drive AgriMaRo (seed ``001``, ch. 2.3, 5.2.3, 6.1.1, 7.2),
    :class:`~terrain.vehicles.swerve.AgriMaRoParams`.
``husky``
    Clearpath Husky A200 four-wheel skid-steer, :class:`~terrain.vehicles.skid_steer.HuskyParams`.
``tracked``
    Patako tracked skid-steer test bed (seed ``003``, Table 2) with the kinematics of seed
    ``000`` (eqs. 1-5), :class:`~terrain.vehicles.skid_steer.TrackedParams`.

Every vehicle exposes :func:`contact_geometry` (contact points, motor map, static loads) used by
the simulator, so the simulator needs no per-vehicle branches for the ground contact.
"""

from __future__ import annotations

from terrain.errors import ConfigError
from terrain.run import VEHICLE_NAMES
from terrain.vehicles.common import ContactGeometry, MotorParams, drive_inertia_kg_m2
from terrain.vehicles.skid_steer import (HUSKY, TRACKED, HuskyParams, TrackedParams,
                                         body_rates, endo_slip_ratio_ratio, side_speeds,
                                         skid_steer_forward,
                                         skid_steer_inverse, skid_steer_pose_rates)
from terrain.vehicles.swerve import (AGRIMARO, AgriMaRoParams, camera_to_robot_velocity,
                                     point_velocity, rim_speed_row, robot_to_camera_velocity,
                                     swerve_forward, swerve_inverse, t265_tracking_to_robot,
                                     wheel_contact_velocity, wheel_rim_speed)


def get_vehicle(name: str) -> AgriMaRoParams | HuskyParams | TrackedParams:
    """Default parameter set of a vehicle by name.

    Parameters
    ----------
    name : str
        One of :data:`VEHICLE_NAMES` (case-insensitive).

    Returns
    -------
    AgriMaRoParams or HuskyParams or TrackedParams
        The shared default instance (frozen).

    Raises
    ------
    ConfigError
        Unknown name; the message lists the valid choices.
    """
    key = str(name).lower()
    table = {"agrimaro": AGRIMARO, "husky": HUSKY, "tracked": TRACKED}
    if key not in table:
        raise ConfigError(f"unknown vehicle {name!r}; valid choices: {', '.join(VEHICLE_NAMES)}")
    return table[key]


def contact_geometry(params: AgriMaRoParams | HuskyParams | TrackedParams) -> ContactGeometry:
    """Contact points, motor assignment and static load shares of a vehicle.

    Parameters
    ----------
    params : AgriMaRoParams or HuskyParams or TrackedParams
        Vehicle parameters.

    Returns
    -------
    ContactGeometry

    Raises
    ------
    ConfigError
        ``params`` not one of the vehicle parameter types (None raised AttributeError).
    """
    if not isinstance(params, (AgriMaRoParams, HuskyParams, TrackedParams)):
        raise ConfigError(f"contact_geometry: params must be AgriMaRoParams, HuskyParams or "
                          f"TrackedParams, got {type(params).__name__}")
    return params.contact_geometry()


__all__ = [
    "AGRIMARO", "HUSKY", "TRACKED", "AgriMaRoParams", "HuskyParams", "TrackedParams",
    "ContactGeometry", "MotorParams", "drive_inertia_kg_m2", "VEHICLE_NAMES", "get_vehicle",
    "contact_geometry",
    "swerve_forward", "swerve_inverse", "wheel_contact_velocity", "camera_to_robot_velocity",
    "robot_to_camera_velocity", "t265_tracking_to_robot", "skid_steer_forward",
    "skid_steer_inverse", "skid_steer_pose_rates", "endo_slip_ratio_ratio", "side_speeds",
    "body_rates",
    "point_velocity", "rim_speed_row", "wheel_rim_speed",
]
