"""Planar rigid-body dynamics of a vehicle on terrain: the integrator (fixed step).

State: pose ``(x, y, yaw)`` on the ground plane, body twist ``V = (v_x, v_y, yaw_rate)``,
motor speeds ``omega`` (rad/s) and, for swerve drives, steering angles ``delta``.

The forces come from the force model :mod:`terrain.sim.forces` (pure functions of state,
commands, terrain and parameters). This module only steps the actuators (steering rate
limit, speed-controlled motors as first-order lags with speed limits) and integrates the body
equations ``M dV/dt = F(V) + Coriolis`` by implicit Euler: a first Newton step
``(M - dt J) dV = dt F(V)`` (the linearly implicit step, ``J = dF/dV`` analytic), then Newton
steps on the residual ``dt F(V + dV) - M dV`` until the velocity error it leaves is below
:data:`IMPLICIT_TOLERANCE_PER_S3` ``dt^2`` (:func:`implicit_euler_step`). Until 2026-11-30 the
first step was the only one: where the traction curve bends within a step (the friction
limit of ice, a spin in place past a peaked curve) its linearisation error decided the run,
so at 100 Hz a Husky ramping on ice slipped 0.11 where the converged model slips 0.01, and a
spin at 0.375 rad/s on packed snow spun out where the converged model grips
(``tests/sim/test_sim_sim24_review.py``, ``tests/sim/test_sim_review_sim17.py``).

Closed loop: an optional hook (:data:`ControlHook`) sees the plant at every time stamp and
returns a wheel speed correction held until its next return (:mod:`terrain.sim.closed_loop`
puts the robot's sensors between the two); without a hook nothing changes.

The mass sits at the vehicle's centre of gravity, the point its static loads balance
(:attr:`terrain.vehicles.common.ContactGeometry.cog_m`: the body origin for the Husky and
the tracked vehicle, the wheel-triangle centroid for the AgriMaRo, seed 001 /
``AgriMaRoParams.cog_m``), in the body-origin twist
(:func:`terrain.sim.forces.rigid_body_terms`); until 2026-11-30 it sat at the body origin
whatever the loads, so a straight AgriMaRo run yawed.

Simplifications (stated): a rigid body, speed-controlled motors as
first-order lags with speed limits; physics ``v1``: static normal loads (no load transfer);
physics ``v2``: quasi-static load transfer from the specific force of the previous step (body
acceleration less gravity along the plane, so a grade shifts load too,
:func:`terrain.sim.forces.specific_force_m_s2`), low-passed with
:data:`LOAD_TRANSFER_TIME_CONSTANT_S` (suspension and tyre compliance), the
lateral wheel-soil model on soils and the tyre's combined-slip law on rigid surfaces
(:mod:`terrain.sim.forces`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace
from typing import Callable, NamedTuple

import numpy as np
from scipy.linalg.lapack import dgesv

from terrain.errors import (ConfigError, NonFiniteInputError, ShapeError, TimeStepError,
                            config_numbers, real_arrays, refuse_booleans)
from terrain.sim.forces import (COMBINED_SLIP, LOAD_TRANSFER, ContactForces,
                                SLIDE_SPEED_M_S, SLIP_SPEED_FLOOR_M_S, SOIL_SPEED_M_S,
                                check_physics, contact_forces, floored_contacts,
                                contact_layout, contact_torque_nm, gravity_force,
                                reach_chord_contact, step_traction_coefficient,
                                rigid_body_terms, specific_force_m_s2,
                                transferred_normal_loads, velocity_maps)
from terrain.terramechanics.lateral import (SOILS, SlipCompactionResistance, SoilContact,
                                            longitudinal_curve, soil_contact)
from terrain.terramechanics.catalogue import TerrainParams
from terrain.terramechanics.resistance import is_deformable
from terrain.terramechanics.slip import sae_slip
from terrain.terramechanics.traction import TractionAndResistance
from terrain.vehicles.common import ContactGeometry, drive_inertia_kg_m2, wrap_angle
from terrain.vehicles.swerve import swerve_inverse
from terrain.vehicles.skid_steer import skid_steer_inverse

__all__ = ["PhysicsResult", "PlantSnapshot", "ControlHook", "integrate", "wheel_commands",
           "implicit_euler_step", "ImplicitStep", "IMPLICIT_TOLERANCE_PER_S3",
           "IMPLICIT_MAX_ITERATIONS",
           "IMPLICIT_ANALYTIC_ITERATIONS", "IMPLICIT_DIFFERENCE_STEP",
           "IMPLICIT_LINE_SEARCH_HALVINGS",
           "slope_attitude", "SLIDE_SPEED_M_S", "SLIP_SPEED_FLOOR_M_S", "SOIL_SPEED_M_S",
           "soil_contacts"]

#: Time constant of the low-pass on the specific force that drives the v2 load transfer, s
#: (ASSUMED: stands for the suspension / tyre compliance; also keeps the one-step-delayed
#: transfer from feeding back on the integrator's step-to-step acceleration).
LOAD_TRANSFER_TIME_CONSTANT_S = 0.05

#: Convergence of the implicit-Euler step, 1/s^3 (m/s^3 on the velocities, rad/s^3 on the
#: yaw rate): the Newton iterations stop once the residual ``M^-1 (dt F(V + dV) - M dV)``
#: is at most this times ``dt^2`` in every component, a local error of the scheme's own
#: order (1e-4 m/s per 10 ms step), so the run converges at first order as the step shrinks.
#: ASSUMED (numerical setting, not a physical constant).
IMPLICIT_TOLERANCE_PER_S3 = 1.0

#: Newton iterations of one implicit-Euler step after its first (linearly implicit) one;
#: a step that has not converged by then keeps its iterate of the smallest velocity error
#: and is counted (:attr:`PhysicsResult.implicit_unconverged_steps`).
IMPLICIT_MAX_ITERATIONS = 50

#: Newton iterations of a step that use the contact laws' analytic Jacobian; later ones use
#: central differences of the forces, whose slopes the laws' secants and a tyre's held peak
#: do not give (on BorealTC's FLOORING runs, physics v2, the analytic slopes alone left 34
#: steps unconverged at 50 iterations, cycling; none with this switch). ASSUMED (numerical
#: setting).
IMPLICIT_ANALYTIC_ITERATIONS = 5

#: Central-difference step of that Jacobian, m/s and rad/s (about the cube root of the
#: float64 resolution times 0.1 m/s, and far below the 0.02 m/s slip-speed floor over which
#: the contact laws bend). ASSUMED (numerical setting).
IMPLICIT_DIFFERENCE_STEP = 1e-6

#: Halvings of a Newton step at most, while its velocity error does not fall (backtracking
#: line search; Dennis and Schnabel, *Numerical Methods for Unconstrained Optimization and
#: Nonlinear Equations*, SIAM 1996, section 6.3). ASSUMED (numerical setting).
IMPLICIT_LINE_SEARCH_HALVINGS = 4


def v2_terrain(terrain, contact: SoilContact, load_n: float):
    """Terrain of physics v2 on a soil: the longitudinal curve from the same soil parameters.

    Only the gross traction ``mu(s)`` changes. The motion resistance stays the catalogue
    terrain's own law, whether that is the constant ``soil_resistance`` (Janosi entries) or a
    law inside the catalogue curve (Brixius entries such as PLOUGHED, whose
    ``soil_resistance`` is 0): :class:`terrain.terramechanics.traction.TractionAndResistance`
    takes the resistance from the catalogue curve.

    Parameters
    ----------
    terrain : TerrainParams
        Catalogue terrain (its resistances and calibrated hysteresis are kept: in steady
        straight driving the torque is ``r N (f_soil + h)`` whatever the curve).
    contact : SoilContact
        Wheel-soil contact of the terrain (:func:`soil_contacts`).
    load_n : float
        Static wheel load, N.

    Returns
    -------
    TerrainParams
        ``terrain`` with ``curve`` = the traction of
        :func:`terrain.terramechanics.lateral.longitudinal_curve` and the motion resistance of
        ``terrain.curve``.
    """
    soil_curve = longitudinal_curve(contact, load_n)
    resistance = terrain.curve
    if contact.soil.slip_sinkage_ratio is not None and contact.soil.slip_compaction:
        resistance = SlipCompactionResistance(terrain.curve, contact, load_n)
    return replace(terrain, curve=TractionAndResistance(
        soil_curve, resistance,
        f"traction: {soil_curve.source}; motion resistance: {terrain.source}"))


def soil_contacts(vehicle, geometry: ContactGeometry, terrains: tuple) -> dict:
    """Tabulated lateral wheel-soil contacts of physics v2, by terrain name.

    Parameters
    ----------
    vehicle : HuskyParams or TrackedParams or AgriMaRoParams
        Vehicle (contact width and length, wheels per motor, mass).
    geometry : ContactGeometry
        Its contact geometry.
    terrains : tuple of TerrainParams
        Terrains of the run; those with an entry in
        :data:`terrain.terramechanics.lateral.SOILS` get a contact.

    Returns
    -------
    dict
        Terrain name -> :class:`~terrain.terramechanics.lateral.SoilContact` (empty for
        steered vehicles and rigid terrains).
    """
    if geometry.steered:
        return {}
    per_side = len(geometry.motor_of_contact) // geometry.n_motors
    footprint = float(vehicle.contact_length_m) * vehicle.wheels_per_motor / per_side
    max_load = 4.0 * float(vehicle.mass_kg) * 9.80665 * float(np.max(geometry.load_share))
    return {t.name: soil_contact(SOILS[t.name], float(vehicle.contact_width_m), footprint,
                                 geometry.wheel_radius_m, max_load)
            for t in terrains if t.name in SOILS}


@dataclass(frozen=True)
class PhysicsResult:
    """Ground truth at every physics step (n steps, m motors).

    Row ``k`` holds the plant at its time stamp ``t_s[k]``: row 0 is the vehicle at rest
    (every scenario starts standing), row ``k + 1`` the state at the end of the step from
    ``t_s[k]`` to ``t_s[k + 1]`` (the command of ``t_s[k]`` applied for one step ``dt``).
    Quantities of a step (acceleration, torque, slip) are stored at the row where the step
    ends; row 0 holds 0 for them (no step has run). Until 2026-11-30 row ``k`` held the
    state at the end of the step starting at ``t_s[k]``, one step ahead of its time stamp
    (``tests/sim/test_sim_sim22_review.py``).

    Parameters
    ----------
    t_s : ndarray, shape (n,)
        Time, s.
    pose : ndarray, shape (n, 3)
        x, y (m, ground plane), yaw (rad, unwrapped).
    twist : ndarray, shape (n, 3)
        v_x, v_y (m/s), yaw_rate (rad/s), body frame.
    accel_body : ndarray, shape (n, 2)
        Body-frame kinematic acceleration ``dV/dt + r x V`` over the step that ends at
        ``t_s[k]`` (0 at row 0), m/s^2.
    omega : ndarray, shape (n, m)
        True motor (wheel) speeds, rad/s.
    omega_cmd : ndarray, shape (n, m)
        Commanded wheel speeds, rad/s (row ``k``: the command of the step that starts at
        ``t_s[k]``).
    slip_motor : ndarray, shape (n, m)
        Mean SAE slip of the contacts of each motor, ``(omega r - v) / max(|omega r|, |v|,
        SLIP_SPEED_FLOOR_M_S)`` (dimensionless).
    delta : ndarray, shape (n, m)
        Steering angles (zeros for skid-steer), rad.
    torque : ndarray, shape (n, m)
        Wheel torque of each motor over the step that ends at ``t_s[k]`` (0 at row 0), N m.
    pitch : ndarray, shape (n,)
        Nose-up inclination, rad.
    roll : ndarray, shape (n,)
        Right-side-down inclination, rad.
    terrain_index : ndarray of int, shape (n,)
        Index into ``terrain_names``.
    terrain_names : tuple of str
        Terrain of each index.
    speed_clipped_steps : ndarray of int, shape (m,)
        Physics steps on which each motor's command from ``twist_cmd`` (before a closed
        loop's correction) exceeded the motor speed limit and was clipped to it.
    correction_clipped_steps : ndarray of int, shape (m,), or None
        Closed loop only (None without a hook): physics steps on which each motor's
        corrected command (low-level command plus the hook's correction) exceeded the motor
        speed limit and was clipped to it.
    load_floor_steps : ndarray of int, shape (c,), or None
        Physics v2 with load transfer only (None without: v1, or a vehicle with no
        centre-of-gravity height): physics steps on which each contact's transferred normal
        load was floored at :data:`terrain.sim.forces.MIN_LOAD_FRACTION` of its static load
        (the transfer asked for less: a wheel about to lift; a load asked for exactly at
        the floor is not counted); the loads are then rescaled to the static total, so a
        floored load ends within that rescaling of the floor, and a load the rescaling
        alone takes below the floor is not counted (:func:`terrain.sim.forces.floored_contacts`).
    implicit_iterations : int
        Newton iterations the implicit-Euler steps took after their first, linearly implicit
        one (:func:`implicit_euler_step`), summed over the run.
    implicit_unconverged_steps : int
        Steps whose Newton iterations stopped at :data:`IMPLICIT_MAX_ITERATIONS` with the
        residual above the tolerance (their iterate of the smallest error is kept).
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
    speed_clipped_steps: np.ndarray
    correction_clipped_steps: np.ndarray | None = None
    load_floor_steps: np.ndarray | None = None
    implicit_iterations: int = 0
    implicit_unconverged_steps: int = 0


class PlantSnapshot(NamedTuple):
    """Physical state at one time stamp of the grid, handed to a closed-loop hook.

    This is the plant, not what a robot measures: a hook must pass it through sensor models
    (:mod:`terrain.sim.closed_loop` does) before anything reaches a controller.

    Parameters
    ----------
    step : int
        Row of :class:`PhysicsResult` (0: the vehicle at rest, before the first step).
    t_s : float
        Its time stamp, ``t_s[step]`` of the grid, s.
    pose : ndarray, shape (3,)
        x, y (m), yaw (rad).
    twist : ndarray, shape (3,)
        v_x, v_y (m/s), yaw_rate (rad/s), body frame.
    accel_body : ndarray, shape (2,)
        Body-frame kinematic acceleration (what an accelerometer senses), m/s^2.
    omega : ndarray, shape (m,)
        Motor (wheel) speeds, rad/s.
    delta : ndarray, shape (m,)
        Steering angles, rad (zeros for skid-steer).
    omega_low_level : ndarray, shape (m,)
        Wheel speed command of the kinematic low level for the next step (from ``t_s``;
        before any correction), rad/s: known to the robot, it is its own command.
    torque : ndarray, shape (m,)
        Wheel torque of each motor over the step that ended at ``t_s`` (0 at rest), N m
        (what the drive's
        current sensor sees, through :func:`terrain.sim.forces.reported_current_a`).
    pitch : float
        Nose-up inclination (:func:`slope_attitude`), rad.
    roll : float
        Right-side-down inclination, rad.
    terrain_index : int
        Index of the terrain under the vehicle into the run's terrain tuple (what shakes the
        IMU).
    """

    step: int
    t_s: float
    pose: np.ndarray
    twist: np.ndarray
    accel_body: np.ndarray
    omega: np.ndarray
    delta: np.ndarray
    omega_low_level: np.ndarray
    torque: np.ndarray
    pitch: float = 0.0
    roll: float = 0.0
    terrain_index: int = 0


#: Closed-loop hook: called at every time stamp of the grid with the plant's state there
#: (first at rest, then after every integrator step); returns a wheel speed correction
#: (rad/s, shape (m,)) added to the low-level command from the step that starts there on
#: (held until the next non-None return), or None to keep the held one.
ControlHook = Callable[[PlantSnapshot], "np.ndarray | None"]


def slope_attitude(slope_rad: float, yaw_rad: np.ndarray | float
                   ) -> tuple[np.ndarray | float, np.ndarray | float]:
    """Pitch and roll of the vehicle on a plane rising along world +x.

    ``pitch = slope cos(yaw)`` (nose-up positive), ``roll = -slope sin(yaw)`` (right side
    down positive).

    Parameters
    ----------
    slope_rad : float
        Plane inclination, rad.
    yaw_rad : float or ndarray, shape (n,)
        Heading, rad.

    Returns
    -------
    pitch, roll : float or ndarray, shape (n,)
        rad.
    """
    return slope_rad * np.cos(yaw_rad), -slope_rad * np.sin(yaw_rad)


def wheel_commands(vehicle, geometry: ContactGeometry, twist_cmd: np.ndarray
                   ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Wheel speed and steering commands from the commanded twist (inverse kinematics).

    Swerve drive: seed 001 inverse kinematics (:func:`terrain.vehicles.swerve.swerve_inverse`),
    each unit keeping the solution closest to its previous angle; skid-steer:
    :func:`terrain.vehicles.skid_steer.skid_steer_inverse`.

    Parameters
    ----------
    vehicle : AgriMaRoParams or HuskyParams or TrackedParams
        Vehicle (track, motor speed limit, swerve geometry).
    geometry : ContactGeometry
        Contact geometry of the vehicle (steered or not, wheel radius).
    twist_cmd : ndarray, shape (n, 3)
        Commanded ``(v_x, v_y, yaw_rate)``, m/s, m/s, rad/s (``v_y`` 0 for a skid-steer).

    Returns
    -------
    omega_cmd : ndarray, shape (n, n_motors), rad/s (clipped to the speed limit, per motor)
    delta_cmd : ndarray, shape (n, n_motors), rad (zeros for skid-steer)
    clipped : ndarray of int, shape (n_motors,)
        Steps on which each motor's command exceeded the speed limit (clipped to it).

    Raises
    ------
    ConfigError
        A lateral velocity ``v_y`` other than 0 for a vehicle that does not steer (its
        inverse kinematics has no ``v_y``: the command was dropped and the run stood
        still), naming the first step.
    """
    n = len(twist_cmd)
    if not geometry.steered and np.any(twist_cmd[:, 1] != 0.0):
        k = int(np.argmax(twist_cmd[:, 1] != 0.0))
        raise ConfigError(f"a skid-steer ({vehicle.name}) cannot follow a lateral velocity "
                          f"command; twist_cmd[:, 1] (v_y) must be 0, got "
                          f"{float(twist_cmd[k, 1])!r} m/s at step {k} "
                          f"({int(np.count_nonzero(twist_cmd[:, 1]))} such steps)")
    wmax = vehicle.motor.max_wheel_speed_rad_s
    if geometry.steered:
        thesis_twist = twist_cmd[:, [2, 0, 1]]          # seed 001 order [yaw_rate, v_x, v_y]
        delta = np.zeros((n, 3))
        omega = np.zeros((n, 3))
        prev = np.zeros(3)
        # sequential so that each unit keeps the solution closest to its previous angle; a
        # repeated command gives the previous solution again (the closest one to itself)
        w = np.zeros(3)
        for i in range(n):
            if i == 0 or not np.array_equal(thesis_twist[i], thesis_twist[i - 1]):
                d, w = swerve_inverse(thesis_twist[i], vehicle, prev, min_speed_m_s=1e-3)
            else:
                d = prev
            delta[i], omega[i] = d, w
            prev = d
    else:
        v_l, v_r = skid_steer_inverse(twist_cmd[:, 0], twist_cmd[:, 2], vehicle.track_m)
        omega = np.column_stack([v_l, v_r]) / geometry.wheel_radius_m
        delta = np.zeros((n, 2))
    clipped = np.count_nonzero(np.abs(omega) > wmax, axis=0)
    return np.clip(omega, -wmax, wmax), delta, clipped


#: Largest departure of a step of the time grid from its first step, as a fraction of it
#: (rounding of a grid far from zero passes; a grid that is not uniform does not).
GRID_STEP_TOLERANCE = 1e-3
#: Relative departure of a grid's first step from its mean step above which the integrator
#: takes the mean step (a clock far from 0 stores its times coarsely: 10 ms steps on an
#: epoch clock, 1.7e9 s, are rounded to 2.4e-7 s, so the first step alone is 2.4e-5 off);
#: below it, the first step (a grid from 0 such as ``arange(n) * dt`` keeps its own step).
GRID_MEAN_STEP_DEPARTURE = 1e-9


def grid_step(t_s: np.ndarray) -> float:
    """The step of a uniform time grid: its first step, or its mean step where rounding of
    the clock takes the first step away from it.

    Parameters
    ----------
    t_s : ndarray, shape (n,)
        Increasing, uniform (within :data:`GRID_STEP_TOLERANCE`) times, s (``n >= 2``).

    Returns
    -------
    float
        ``t_s[1] - t_s[0]``, or ``(t_s[-1] - t_s[0]) / (n - 1)`` where the two depart by
        more than :data:`GRID_MEAN_STEP_DEPARTURE` of it (so the steps sum to the grid's
        span), s.
    """
    first = float(t_s[1] - t_s[0])
    mean = float(t_s[-1] - t_s[0]) / (len(t_s) - 1)
    return mean if abs(first - mean) > GRID_MEAN_STEP_DEPARTURE * mean else first


def _check_grid_and_commands(t_s: np.ndarray, twist_cmd: np.ndarray) -> np.ndarray:
    """Refuse a time grid that is not finite, increasing and uniform, or a command without
    one finite ``(v_x, v_y, yaw_rate)`` per step; return the command as a float array.

    Raises
    ------
    ConfigError
        ``t_s`` or ``twist_cmd`` given as booleans, or a grid of fewer than two times.
    ShapeError
        ``t_s`` not one-dimensional (a number, None, a 2-D array), or ``twist_cmd`` not of
        shape ``(len(t_s), 3)``.
    NonFiniteInputError
        NaN or infinite times or commands.
    TimeStepError
        A first step that is not > 0, or a step that departs from it by more than
        :data:`GRID_STEP_TOLERANCE` of it (the integrator reads the step from the first two
        times only).
    """
    refuse_booleans(ConfigError, "integrate", t_s=t_s)
    refuse_booleans(ConfigError, "integrate", twist_cmd=twist_cmd)
    t = np.asarray(t_s, dtype=float)
    if t.ndim != 1:
        # (a number or None was a bare TypeError of len() before this check was reached)
        raise ShapeError(f"integrate: t_s must be one-dimensional, got shape {t.shape}")
    if len(t) < 2:
        raise ConfigError(f"the time grid needs at least 2 steps to integrate, got {len(t)} "
                          "(a duration shorter than one physics step?)")
    if not np.all(np.isfinite(t)):
        raise NonFiniteInputError(f"integrate: t_s holds {int(np.sum(~np.isfinite(t)))} "
                                  "non-finite times")
    steps = np.diff(t)
    if not steps[0] > 0:
        raise TimeStepError(f"integrate: the time grid t_s must increase, its first step is "
                            f"{steps[0]!r} s")
    worst = int(np.argmax(np.abs(steps - steps[0])))
    if abs(steps[worst] - steps[0]) > GRID_STEP_TOLERANCE * steps[0]:
        raise TimeStepError(f"integrate: the time grid t_s must be uniform (the step is read "
                            f"from its first two times, {steps[0]:g} s); step {worst} is "
                            f"{steps[worst]:g} s")
    cmd = np.asarray(twist_cmd, dtype=float)
    if cmd.shape != (len(t), 3):
        raise ShapeError(f"integrate: twist_cmd must have shape ({len(t)}, 3), one "
                         f"(v_x, v_y, yaw_rate) per time of t_s, got {cmd.shape}")
    bad = ~np.isfinite(cmd).all(axis=1)
    if bad.any():
        k = int(np.argmax(bad))
        raise NonFiniteInputError(f"integrate: twist_cmd holds non-finite commands on "
                                  f"{int(bad.sum())} steps, the first at step {k} "
                                  f"(t = {t[k]:.3f} s): {cmd[k].tolist()}")
    return cmd


def _checked_steer_offset(steer_offset_rad, geometry: ContactGeometry) -> np.ndarray:
    """The steering offset as one finite angle per motor of a steered vehicle, rad.

    Raises
    ------
    ConfigError
        An offset for a vehicle that does not steer (it was silently ignored), or booleans.
    ShapeError
        Not one angle per motor (a bare broadcasting ValueError).
    NonFiniteInputError
        A NaN or infinite angle (a bare ValueError deep in the step).
    """
    if not geometry.steered:
        raise ConfigError("integrate.steer_offset_rad is a swerve-drive steering error; this "
                          "vehicle does not steer, so it would change nothing: leave it None")
    refuse_booleans(ConfigError, **{"integrate.steer_offset_rad": steer_offset_rad})
    offset = np.asarray(steer_offset_rad, dtype=float)
    if offset.shape != (geometry.n_motors,):
        raise ShapeError(f"integrate.steer_offset_rad must hold one angle per motor, shape "
                         f"({geometry.n_motors},), got shape {offset.shape}")
    if not np.all(np.isfinite(offset)):
        raise NonFiniteInputError(f"integrate.steer_offset_rad holds non-finite angles: "
                                  f"{offset.tolist()}")
    return offset


class ImplicitStep(NamedTuple):
    """One implicit-Euler step of the body twist (:func:`implicit_euler_step`).

    Parameters
    ----------
    dv : ndarray, shape (3,)
        Twist change of the step, m/s, m/s, rad/s.
    linearised : ContactForces
        The contact forces whose linearisation gave the last Newton step (the step's first
        contact forces when there was only one). Where that step is ``exact`` the body
        received ``linearised.force + linearised.jacobian last_step``
        (:func:`terrain.sim.forces.step_traction_coefficient`); elsewhere the step's matrix
        was not ``linearised.jacobian`` (central differences) or the step was halved, and
        the body received ``end.force`` within the tolerance (``M`` tolerance ``/ dt`` in
        force) where the step converged.
    last_step : ndarray, shape (3,)
        That last Newton step, m/s, m/s, rad/s.
    iterations : int
        Newton steps after the first.
    converged : bool
        False where the iterations stopped at the limit with the residual above tolerance
        (``dv`` is then the iterate of the smallest velocity error).
    exact : bool
        True where the last Newton step was a full step solved with
        ``linearised.jacobian`` itself: the linearly implicit step, or a full Newton step
        within the first :data:`IMPLICIT_ANALYTIC_ITERATIONS` (the contact laws' own slopes).
    end : ContactForces
        The contact forces at the returned twist ``vel + dv``.
    """

    dv: np.ndarray
    linearised: ContactForces
    last_step: np.ndarray
    iterations: int
    converged: bool
    exact: bool
    end: ContactForces


def implicit_euler_step(m_mat: np.ndarray, m_inv: np.ndarray, dt: float, vel: np.ndarray,
                        first: ContactForces, force: np.ndarray,
                        contact_at: Callable[[np.ndarray], ContactForces],
                        where: str = "") -> ImplicitStep:
    """One implicit-Euler step of the body twist, ``M dV = dt (F(V + dV) + G)``, by Newton.

    The first Newton step is the linearly implicit one, ``(M - dt J) dV = dt (F(V) + G)``
    with the Jacobian of ``first`` (the contact forces at the start of the step, their
    traction slopes possibly taken as chords, :func:`terrain.sim.forces.reach_chord_contact`).
    Each further step solves ``(M - dt J(V + dV)) d = R`` for the residual
    ``R = dt (F(V + dV) + G) - M dV``, until ``|M^-1 R|`` is at most
    :data:`IMPLICIT_TOLERANCE_PER_S3` ``dt^2`` in every component, or
    :data:`IMPLICIT_MAX_ITERATIONS` further steps have run. ``J`` is the contact laws' own
    Jacobian for the first :data:`IMPLICIT_ANALYTIC_ITERATIONS` steps, then the forces'
    central differences; a step whose velocity error does not fall is halved up to
    :data:`IMPLICIT_LINE_SEARCH_HALVINGS` times, the full step taken where no halving lowers it
    (without both, Newton cycled across the kinks
    of physics v2's tyre law on rigid ground at low speed). A step that does not converge
    keeps the iterate of the smallest error. ``G`` (gravity and the transport terms) is held
    at the start of the step, as before; only the contact forces are implicit. Where the
    contact forces are linear over the step the first step already solves the equation and
    the result is the linearly implicit step's, bit for bit.

    Parameters
    ----------
    m_mat, m_inv : ndarray, shape (3, 3)
        Rigid-body mass matrix about the body origin and its inverse
        (:func:`terrain.sim.forces.rigid_body_terms`), kg, kg m, kg m^2.
    dt : float
        Step, s (> 0).
    vel : ndarray, shape (3,)
        Twist at the start of the step ``(v_x, v_y, yaw_rate)``, m/s, m/s, rad/s.
    first : ContactForces
        Contact forces at ``vel`` (:func:`terrain.sim.forces.contact_forces`).
    force : ndarray, shape (3,)
        Generalised force at the start of the step, ``F(V) + G``: ``first.force`` plus the
        terms held over the step (gravity, transport terms), N, N, N m.
    contact_at : callable
        ``contact_at(twist) -> ContactForces``: the contact forces at another twist with
        the step's wheel speeds, loads, maps and terrain.
    where : str
        The step, for the error message (e.g. ``"step 12 (t = 0.120 s)"``).

    Returns
    -------
    ImplicitStep
        ``(dv, linearised, last_step, iterations, converged, exact, end)``: the twist
        change, what the body received over the step and whether the step converged.

    Raises
    ------
    numpy.linalg.LinAlgError
        A singular implicit-Euler matrix ``M - dt J`` (not seen with the catalogue's
        vehicles and terrains).
    NonFiniteInputError
        NaN or infinite forces at the start of the step or at its linearly implicit iterate
        (``where`` named); a later iterate's are halved back from, or leave the step
        unconverged with its best finite iterate.

    Notes
    -----
    Backward (implicit) Euler for the stiff wheel-ground forces, solved by Newton's method;
    Hairer and Wanner, *Solving Ordinary Differential Equations II* (2nd ed., Springer 1996),
    sections IV.8 (the simplified Newton iterations of implicit methods) and IV.9 (the
    linearly implicit Rosenbrock-Euler step, the first iterate here); the backtracking line
    search of Dennis and Schnabel, *Numerical Methods for Unconstrained Optimization and
    Nonlinear Equations* (SIAM 1996), section 6.3.
    """
    _, _, dv, info = dgesv(m_mat - dt * first.jacobian, dt * force)
    if info != 0:
        raise np.linalg.LinAlgError(f"singular implicit-Euler matrix at {where}")
    linearised, last = first, dv
    other_force = force - first.force
    tolerance = IMPLICIT_TOLERANCE_PER_S3 * dt * dt

    def residual_at(change):
        """The contact forces at ``vel + change``, the residual and its velocity error."""
        at = contact_at(vel + change)
        res = dt * (at.force + other_force) - m_mat @ change
        # the array's own max: np.max's reduction (NaN propagated) without its wrapper
        return at, res, float(np.abs(m_inv @ res).max())

    contact, residual, error = residual_at(dv)
    if not math.isfinite(error):
        # a NaN error compares False with everything: the NaN step was returned as the
        # 'best' iterate and the run went on with NaN states
        where_forces = ("at the start of the step" if not np.all(np.isfinite(dv))
                        else f"at the linearly implicit step's twist {(vel + dv).tolist()}")
        raise NonFiniteInputError(f"non-finite forces {where_forces} at {where} (the "
                                  f"implicit-Euler step cannot be solved)")
    exact = True
    best = (error, dv, linearised, last, exact, contact)
    iterations = 0
    while error > tolerance and iterations < IMPLICIT_MAX_ITERATIONS:
        jacobian = contact.jacobian
        if iterations >= IMPLICIT_ANALYTIC_ITERATIONS:
            # the contact laws' own slopes (secants, chords, a tyre's held peak) have not
            # converged: the Jacobian of the forces themselves, by central differences
            # (mirrored twists give mirrored columns, so left and right turns stay mirrors)
            h = IMPLICIT_DIFFERENCE_STEP
            jacobian = np.column_stack([
                (contact_at(vel + dv + h * unit).force
                 - contact_at(vel + dv - h * unit).force) / (2.0 * h) for unit in np.eye(3)])
        _, _, step, info = dgesv(m_mat - dt * jacobian, residual)
        if info != 0:
            raise np.linalg.LinAlgError(f"singular implicit-Euler matrix at {where} "
                                        f"(Newton iteration {iterations + 1})")
        # backtracking: halve the step until the velocity error falls (at most
        # IMPLICIT_LINE_SEARCH_HALVINGS times), so an iteration cannot jump across a kink
        full = (1.0, dv + step, *residual_at(dv + step))
        scale, trial, trial_contact, trial_residual, trial_error = full
        for _ in range(IMPLICIT_LINE_SEARCH_HALVINGS):
            if trial_error < error:
                break
            scale *= 0.5
            trial = dv + scale * step
            trial_contact, trial_residual, trial_error = residual_at(trial)
        else:
            if trial_error >= error:
                # no halving lowers the error: the full step (the residual of a step
                # towards a root further away can rise on the way)
                scale, trial, trial_contact, trial_residual, trial_error = full
        # the body receives the linearisation of ``contact`` over the step only where the
        # step is full and solved with ``contact.jacobian`` itself
        exact = scale == 1.0 and iterations < IMPLICIT_ANALYTIC_ITERATIONS
        iterations += 1
        linearised, last = contact, scale * step
        dv, contact, residual, error = trial, trial_contact, trial_residual, trial_error
        if error < best[0]:
            best = (error, dv, linearised, last, exact, contact)
    if error <= tolerance:
        return ImplicitStep(dv, linearised, last, iterations, True, exact, contact)
    _, dv, linearised, last, exact, contact = best
    return ImplicitStep(dv, linearised, last, iterations, False, exact, contact)


def integrate(vehicle, geometry: ContactGeometry, terrains: tuple, segment_length_m: float,
              t_s: np.ndarray, twist_cmd: np.ndarray, slope_rad: float, chi: float,
              steer_offset_rad: np.ndarray | None = None,
              hook: ControlHook | None = None, physics: str = "v1") -> PhysicsResult:
    """Integrate the vehicle dynamics over the command sequence.

    Parameters
    ----------
    vehicle : AgriMaRoParams or HuskyParams or TrackedParams
        Vehicle (mass, yaw inertia, motor, wheels per motor, steering rate).
    geometry : ContactGeometry
        Its contact geometry.
    terrains : tuple of TerrainParams
        Terrain sequence along the path; the vehicle changes terrain every
        ``segment_length_m`` of travelled distance, cycling through the tuple.
    segment_length_m : float
        Distance between terrain changes, m (> 0; inf: the first terrain all along).
    t_s : ndarray, shape (n,)
        Uniform, increasing time grid, s (n >= 2: the step is ``t_s[1] - t_s[0]``, or the
        mean step where the clock's rounding takes the first one away from it,
        :func:`grid_step`).
    twist_cmd : ndarray, shape (n, 3)
        Commanded ``(v_x, v_y, yaw_rate)``, m/s, m/s, rad/s (``v_y`` 0 for a skid-steer).
    slope_rad : float
        Plane inclination (rises along world +x; negative: falls along it), rad, in
        (-pi/2, pi/2).
    chi : float
        ICR expansion (skid-steer only: 1 for a steered vehicle; 1 = off; finite, >= 1).
    steer_offset_rad : ndarray, shape (n_motors,), optional
        Constant steering error inside the dead band, rad (swerve only: refused for a
        vehicle that does not steer).
    hook : ControlHook, optional
        Closed loop: called at every time stamp with a :class:`PlantSnapshot` of the plant
        there (first at rest, then after every step); the correction it returns (rad/s per
        motor) is added to the low-level wheel command of the steps from that time on, the
        sum clipped to the speed limit (counted in ``correction_clipped_steps``), and
        ``omega_cmd`` of the result records the corrected command. None (default): open
        loop, the commands of ``twist_cmd`` unchanged (bit-identical to a run without the
        argument).
    physics : str
        ``v1`` (static loads, Coulomb lateral friction) or ``v2`` (load transfer, lateral
        wheel-soil model on soils), :data:`terrain.sim.forces.PHYSICS_VERSIONS`.

    Returns
    -------
    PhysicsResult
        Ground truth at every step of ``t_s``.

    Raises
    ------
    ConfigError
        Unknown physics version, a time grid of fewer than two steps, no terrain, terrains
        that are not a tuple (or list) of TerrainParams (one TerrainParams, names), a segment
        length not > 0 (inf keeps the first terrain), a slope that is not a finite
        inclination in (-pi/2, pi/2), a ``chi`` that is not finite and >= 1 (or not 1 for
        a steered vehicle, which it would not change), or a segment
        length, slope or ``chi`` given as text, None or a boolean, or ``t_s``,
        ``twist_cmd``, ``steer_offset_rad`` or a hook's correction given as booleans, a
        lateral velocity command (``v_y`` not 0) for a vehicle that does not steer, or a
        ``hook`` that is not callable.
    DataFormatError
        The hook returned a correction that is not real numbers (text, a mapping, complex
        numbers, a ragged list), naming the step (:func:`terrain.errors.real_arrays`).
    TimeStepError
        A time grid that does not increase or is not uniform (within
        :data:`GRID_STEP_TOLERANCE` of its first step).
    ShapeError
        ``t_s`` not one-dimensional (a number or None included), ``twist_cmd`` not of shape
        ``(n, 3)``,
        ``steer_offset_rad`` not of shape ``(n_motors,)``, or the hook returned a correction
        without one value per motor.
    NonFiniteInputError
        NaN or infinite times, commands or steering offsets, or the hook returned a NaN or
        infinite correction; non-finite forces in a step (:func:`implicit_euler_step`, not
        seen with the catalogue's vehicles and terrains).
    numpy.linalg.LinAlgError
        The implicit-Euler matrix ``M - dt J`` is singular (not seen with the catalogue's
        vehicles and terrains).
    """
    check_physics(physics)
    if hook is not None and not callable(hook):
        # 5 was a bare TypeError ('int' object is not callable) after the first step
        raise ConfigError(f"integrate.hook must be callable, hook(PlantSnapshot) -> "
                          f"correction or None, got {type(hook).__name__}")
    twist_cmd = _check_grid_and_commands(t_s, twist_cmd)
    if isinstance(terrains, TerrainParams) or not isinstance(terrains, (tuple, list)):
        raise ConfigError(f"integrate.terrains must be a tuple of TerrainParams "
                          f"(terrain.terramechanics.catalogue.get_terrain), got "
                          f"{type(terrains).__name__}")
    if not len(terrains):
        raise ConfigError("integrate needs at least one terrain, got an empty terrain tuple")
    for i, ter in enumerate(terrains):
        if not isinstance(ter, TerrainParams):
            raise ConfigError(f"integrate.terrains[{i}] must be a TerrainParams "
                              f"(terrain.terramechanics.catalogue.get_terrain), got {ter!r}")
    # text or None was a bare TypeError below; True ran as 1 (slope_rad: a 57 deg plane)
    config_numbers("integrate", segment_length_m=segment_length_m, slope_rad=slope_rad,
                   chi=chi)
    if not float(segment_length_m) > 0:      # (inf: the first terrain all along)
        raise ConfigError(f"integrate.segment_length_m must be > 0 m, got {segment_length_m}")
    if not abs(float(slope_rad)) < 0.5 * np.pi:     # (NaN and inf fail it too)
        # steeper than vertical: cos(slope) < 0 gave negative normal loads, 2 pi a level plane
        raise ConfigError(f"integrate.slope_rad must be a finite inclination in (-pi/2, pi/2) "
                          f"rad, got {slope_rad}")
    if not (np.isfinite(chi) and chi >= 1.0):
        raise ConfigError(f"integrate.chi (ICR expansion) must be finite and >= 1, got {chi}")
    if geometry.steered and chi != 1.0:
        # contact_layout applies chi to skid-steers only: it was ignored (as steer_offset_rad
        # for a vehicle that does not steer, refused below)
        raise ConfigError(f"integrate.chi is a skid-steer's ICR expansion; this vehicle "
                          f"steers, so chi {chi} would change nothing: give 1")
    # the mean step where a clock far from 0 rounds the first one (an epoch grid)
    dt = grid_step(np.asarray(t_s, dtype=float))
    n = len(t_s)
    nm = geometry.n_motors
    layout = contact_layout(geometry, vehicle.mass_kg, slope_rad, chi)
    v2 = physics == "v2"
    soils: dict[str, SoilContact] = soil_contacts(vehicle, geometry, terrains) if v2 else {}
    if soils:
        terrains = tuple(v2_terrain(t, soils[t.name], float(np.mean(layout.normal_load_n)))
                         if t.name in soils else t for t in terrains)
    tyre = COMBINED_SLIP.get(vehicle.name) if v2 else None
    if tyre is not None:
        # this tyre's friction on the rigid surfaces it has a factor for
        terrains = tuple(t if is_deformable(t) else replace(t, curve=tyre.surface_curve(
            t.name, t.curve)) for t in terrains)
    # side-force factor per terrain index: the tyre's combined-slip law on rigid surfaces
    side_factor = [tyre.side_force_factor if (tyre is not None and not is_deformable(t))
                   else None for t in terrains]
    hold_slip = [tyre.hold_slip(t.curve) if f is not None else 1.0
                 for t, f in zip(terrains, side_factor)]
    mass = vehicle.mass_kg
    # a vehicle that carries its CoG height (TrackedParams, seed 003 Table 2) uses its own;
    # the others the table of terrain.sim.forces
    lt = LOAD_TRANSFER.get(vehicle.name)
    own_h = getattr(vehicle, "cog_height_m", None)
    if not v2:
        cog_h = 0.0
    elif own_h is not None:
        cog_h = float(own_h)
    else:
        cog_h = lt.cog_height_m if lt is not None else 0.0
    alpha_lt = min(1.0, dt / LOAD_TRANSFER_TIME_CONSTANT_S)
    # low-passed specific force of the load transfer, started at rest on the plane (yaw 0):
    # gravity alone, so a vehicle that starts on a grade starts with its static transfer
    acc_lt = specific_force_m_s2(np.zeros(2), gravity_force(mass, slope_rad, 0.0), mass)
    normal = None
    # steps on which each contact's transferred load was floored (counted, not hidden)
    load_floor = np.zeros(len(layout.normal_load_n), dtype=np.int64) if cog_h > 0 else None
    motor_of = layout.motor_of
    # the mass at the centre of gravity the static loads balance (the body origin for a
    # symmetric layout), in the body-origin twist
    cog = geometry.cog_m
    m_mat, transport = rigid_body_terms(mass, vehicle.yaw_inertia_kg_m2, cog)
    m_inv = np.linalg.inv(m_mat)
    # contact positions about the centre of gravity (the load transfer's lever arms)
    x_cg, y_cg = layout.x_m - cog[0], layout.y_m - cog[1]
    motor = vehicle.motor
    alpha_m = min(1.0, dt / motor.speed_time_constant_s)
    counts = np.bincount(motor_of, minlength=nm).astype(float)
    # inertia each motor turns: its physical wheels (or sprocket), not its contact points
    drive_inertia = drive_inertia_kg_m2(vehicle)
    steer_rate = getattr(vehicle, "steering_rate_rad_s", 0.0) * dt

    omega_cmd, delta_cmd, clipped = wheel_commands(vehicle, geometry, twist_cmd)
    omega_ll = omega_cmd
    correction = np.zeros(nm)
    wmax = motor.max_wheel_speed_rad_s
    corr_clipped = None
    if hook is not None:
        omega_cmd = omega_cmd.copy()
        corr_clipped = np.zeros(nm, dtype=np.int64)
    if steer_offset_rad is not None:
        delta_cmd = delta_cmd + _checked_steer_offset(steer_offset_rad, geometry)

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
    n_iter = n_unconverged = 0
    omega = np.zeros(nm)
    delta = delta_cmd[0].copy()
    dist = 0.0
    n_terr = len(terrains)
    fixed_maps = None if layout.steered else velocity_maps(layout, np.zeros_like(layout.x_m))

    def snapshot(k: int) -> None:
        """Hand the hook the plant at t_s[k] (row k); keep the correction it returns."""
        nonlocal correction
        pitch_k, roll_k = (slope_attitude(slope_rad, pose_out[k, 2]) if slope_rad
                           else (0.0, 0.0))
        new = hook(PlantSnapshot(k, float(t_s[k]), pose_out[k].copy(), twist_out[k].copy(),
                                 acc_out[k].copy(), omega_out[k].copy(), delta_out[k].copy(),
                                 omega_ll[k].copy(), torque_out[k].copy(), float(pitch_k),
                                 float(roll_k), int(terr_out[k])))
        if new is not None:
            # booleans refused, then text, a mapping or complex numbers (bare ValueErrors
            # and TypeErrors of NumPy), each naming the step
            new, = real_arrays("integrate", ConfigError,
                               **{f"the closed-loop hook's correction at step {k}": new})
            if new.size != nm:
                raise ShapeError(f"the closed-loop hook returned {new.size} values for "
                                 f"{nm} motors at step {k} (t = {t_s[k]:.3f} s), shape "
                                 f"{new.shape}")
            if not np.all(np.isfinite(new)):
                raise NonFiniteInputError(f"the closed-loop hook returned a non-finite "
                                          f"correction {new.ravel().tolist()} rad/s at "
                                          f"step {k} (t = {t_s[k]:.3f} s)")
            correction = new.reshape(nm)

    # row 0: the vehicle at rest at t_s[0] (no step has run: no acceleration, torque or slip)
    delta_out[0] = delta if layout.steered else 0.0
    for k in range(n):
        # row k is the plant at t_s[k]; the step from t_s[k] to t_s[k + 1] (command k) writes
        # row k + 1
        if hook is not None:
            snapshot(k)
            wanted = omega_ll[k] + correction
            corr_clipped += np.abs(wanted) > wmax
            omega_cmd[k] = np.clip(wanted, -wmax, wmax)
        if k == n - 1:
            break
        ti = int(dist // segment_length_m) % n_terr
        ter = terrains[ti]
        # actuators: steering (rate-limited), speed loop (first-order lag)
        if layout.steered:
            step = wrap_angle(delta_cmd[k] - delta)
            delta = delta + np.minimum(np.maximum(step, -steer_rate), steer_rate)
            d_c = delta[motor_of]
            maps = velocity_maps(layout, d_c)
        else:
            maps = fixed_maps
        omega_prev = omega
        omega = omega + alpha_m * (omega_cmd[k] - omega)
        dw = (omega - omega_prev) / dt
        # force model, then gravity and the velocity terms of the body-frame equations
        if cog_h > 0:
            normal = transferred_normal_loads(layout.normal_load_n, x_cg, y_cg,
                                              mass, cog_h, acc_lt[0], acc_lt[1])
            # the loads the transfer asked below the floor (not those the rescaling took
            # below it)
            load_floor += floored_contacts(layout.normal_load_n, x_cg, y_cg,
                                           mass, cog_h, acc_lt[0], acc_lt[1])
        soil_k, side_k, hold_k = soils.get(ter.name), side_factor[ti], hold_slip[ti]

        def contact_at(twist):
            """The contact forces of this step (its wheel speeds, loads, maps, terrain)."""
            return contact_forces(layout, maps, ter, twist, omega, normal, soil_k, side_k,
                                  hold_k)

        contact = contact_at(vel)
        gravity = gravity_force(mass, slope_rad, pose[2], cog)
        # transport (Coriolis, centripetal) terms of the body-frame equations about the
        # origin: m (dv_x/dt - r v_y) = F_x ... for a mass at the origin
        force = contact.force + gravity
        force += (mass * vel[2]) * (transport @ vel)
        # traction slopes over the slip the step can reach (the explicit step's) where the
        # curve has flattened; the tyre's combined-slip law keeps its own (contact.slip None)
        if contact.slip is not None:
            contact = reach_chord_contact(contact, layout, maps, ter,
                                          dt * (m_inv @ force), normal, soil_k)
        # implicit Euler, Newton steps from the linearly implicit one (LAPACK gesv, LU with
        # partial pivoting, as numpy.linalg.solve, without its per-call overhead)
        implicit = implicit_euler_step(
            m_mat, m_inv, dt, vel, contact, force, contact_at, f"step {k} (t = {t_s[k]:.3f} s)")
        n_iter += implicit.iterations
        n_unconverged += not implicit.converged
        vel_new = vel + implicit.dv
        j = k + 1
        acc_out[j] = [(vel_new[0] - vel[0]) / dt - vel[2] * vel[1],
                      (vel_new[1] - vel[1]) / dt + vel[2] * vel[0]]
        vel = vel_new
        acc_lt = acc_lt + alpha_lt * (specific_force_m_s2(acc_out[j], gravity, mass) - acc_lt)
        # pose on the plane
        yaw_mid = pose[2] + 0.5 * dt * vel[2]
        cm, sm = np.cos(yaw_mid), np.sin(yaw_mid)
        pose = pose + dt * np.array([vel[0] * cm - vel[1] * sm, vel[0] * sm + vel[1] * cm,
                                     vel[2]])
        dist += dt * float(np.hypot(vel[0], vel[1]))
        # motor torque: traction plus torque-only hysteresis, plus wheel inertia; the
        # traction the body received over the step: the implicit step's linearisation where
        # its last Newton step was exact (full, on the contact laws' own slopes), else the
        # traction at the converged twist, within the step's tolerance of what the body
        # received (M tolerance / dt in force; until 2026-11-30 the linearisation there
        # too, off by up to 0.009 of mu per contact on ICE, 0.018 on PACKED_SNOW)
        mu_step = (step_traction_coefficient(implicit.linearised, maps, implicit.last_step)
                   if implicit.exact else implicit.end.mu)
        t_contact = contact_torque_nm(layout, ter, mu_step, contact.rim_speed_m_s, normal)
        torque = np.bincount(motor_of, weights=t_contact, minlength=nm) + drive_inertia * dw
        pose_out[j] = pose
        twist_out[j] = vel
        omega_out[j] = omega
        # slip reported consistently with the stored (end-of-step) velocity
        slip_new = sae_slip(contact.rim_speed_m_s, maps.long_kinematic @ vel,
                            speed_floor_m_s=SLIP_SPEED_FLOOR_M_S, dead_band_m_s=0.0)
        slip_out[j] = np.bincount(motor_of, weights=slip_new, minlength=nm) / counts
        delta_out[j] = delta if layout.steered else 0.0
        torque_out[j] = torque
        # the terrain under the vehicle at t_s[j] (where it has arrived)
        terr_out[j] = int(dist // segment_length_m) % n_terr
    yaw = pose_out[:, 2]
    pitch, roll = slope_attitude(slope_rad, yaw) if slope_rad else (np.zeros(n), np.zeros(n))
    return PhysicsResult(t_s=t_s, pose=pose_out, twist=twist_out, accel_body=acc_out,
                         omega=omega_out, omega_cmd=omega_cmd, slip_motor=slip_out,
                         delta=delta_out, torque=torque_out, pitch=pitch, roll=roll,
                         terrain_index=terr_out,
                         terrain_names=tuple(t.name for t in terrains),
                         speed_clipped_steps=clipped,
                         correction_clipped_steps=corr_clipped,
                         load_floor_steps=load_floor, implicit_iterations=int(n_iter),
                         implicit_unconverged_steps=int(n_unconverged))
