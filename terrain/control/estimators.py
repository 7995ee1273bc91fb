"""The closed loop's slip estimators: what the robot knows of its wheels' ground speed.

Every estimator has the :class:`SlipEstimator` interface: the closed loop
(:class:`terrain.control.closed_loop.TractionLoop`) hands it each
:class:`~terrain.sim.closed_loop.Observation` (sensor samples since the previous call) and
reads back a :class:`VelocityEstimate`, one entry per drive unit. :func:`estimator_for`
builds the one a vehicle has (:data:`ESTIMATORS`).

* :class:`AgriMaRoVisualOdometryEKF`: the 12-state EKF of seed 001 ch. 6.1
  (:class:`terrain.estimation.agrimaro.AgriMaRoModel`) run streaming on IMU, wheel encoders,
  steering encoders and the T265 velocity: the vehicle's real estimator. The camera is the
  velocity reference, so the estimate is *stale* during camera outages (its age is the time
  since the last camera sample).
* :class:`FusedSlipObserver` (the Husky's default): the fused slip estimate of the
  slip-learning work (issue 10) run online: the slip-augmented skid-steer EKF on wheels and
  the gyro of the full IMU (its accelerometer only with ``imu="full"``, which takes the
  terrain's vibration for acceleration) with the physics slip from the motor currents as
  pseudo-measurement of the side slips. It needs the motor currents, which the closed
  loop's sensors sample from the plant's wheel torque
  (:class:`terrain.sim.closed_loop.OnlineSensors`); without them the common slip of both
  sides is unobservable and the estimate drifts (stated in results as
  ``estimator_pseudo_measurements`` = 0).
* :class:`WheelImuObserver` (``--estimator observer``): the earlier interim estimator:
  forward speed from the integrated accelerometer, pulled towards the *slower* side's wheel
  speed with time constant ``tau_s``. Limits: a slip common to both sides is observable only
  for times short against ``tau_s``; in steady slipping the estimate converges to the slower
  wheel and the estimated slip to zero; an accelerometer bias ``b`` gives a speed error
  ``b tau_s``.
"""

from __future__ import annotations

import math
from collections import deque
from dataclasses import replace
from types import MappingProxyType
from typing import Callable, Mapping, NamedTuple, Protocol

import numpy as np

from terrain.errors import ConfigError, config_integer, config_positive
from terrain.estimation.agrimaro import SENSOR_ROWS, AgriMaRoModel, noise_derived_settings
from terrain.estimation.ekf import ExtendedKalmanFilter, correct, predict, project_to_bounds
from terrain.estimation.skid_steer_slip import SENSOR_ROWS as SLIP_SENSOR_ROWS
from terrain.estimation.equations.skid_steer_slip import MAX_SLIP
from terrain.estimation.skid_steer_slip import (SPEED_BOUND_MOVABLE, STATE_NAMES,
                                                SkidSteerSlipModel, SkidSteerSlipSettings,
                                                rim_speed_range_m_s)
from terrain.run import clock_slack
from terrain.sim.closed_loop import Observation
from terrain.slip.estimate import FusionSettings, pseudo_measurement
from terrain.slip.physics import PhysicsSlipSettings, physics_slip
from terrain.terramechanics.catalogue import TERRAIN_NAMES
from terrain.terramechanics.slip import ground_speed_from_slip
from terrain.vehicles import HuskyParams, TrackedParams, get_vehicle
from terrain.vehicles.swerve import wheel_rim_speed


class VelocityEstimate(NamedTuple):
    """What the controller needs from an estimator, one entry per drive unit.

    Parameters
    ----------
    omega_meas_rad_s : ndarray, shape (n,)
        Latest raw encoder wheel speed, rad/s.
    v_long_m_s : ndarray, shape (n,)
        Estimated longitudinal speed of each wheel centre (skid-steer: each side), m/s.
    a_local_m_s2 : ndarray, shape (n,)
        Estimated longitudinal acceleration of each wheel centre, m/s^2.
    chassis_speed_m_s : float
        Estimated chassis speed magnitude, m/s.
    age_s : float
        Age of the velocity reference (camera, or wheel sample; :class:`FusedSlipObserver`:
        also its slip pseudo-measurement), s; inf before the first.
    """

    omega_meas_rad_s: np.ndarray
    v_long_m_s: np.ndarray
    a_local_m_s2: np.ndarray
    chassis_speed_m_s: float
    age_s: float


class SlipEstimator(Protocol):
    """Estimator interface of the closed loop.

    Attributes
    ----------
    name : str
        Short name (recorded in results).
    limits : str
        What it cannot see (recorded in results).
    """

    name: str
    limits: str

    def update(self, obs: Observation) -> VelocityEstimate:
        """Fold in the new samples and return the current estimate.

        Parameters
        ----------
        obs : Observation
            Samples since the previous call.

        Returns
        -------
        VelocityEstimate
        """
        ...


def _merged(obs: Observation, imu_view: str = "clean") -> list[tuple[float, str, np.ndarray]]:
    """Every sample of an observation in time order, as ``(t, stream, values)``; the IMU
    stream of the view (:data:`IMU_VIEWS`): ``imu`` for ``clean``, ``imu_full`` otherwise.
    Samples of a non-finite time come last (a NaN key left the list unsorted); the
    estimators skip and count them (``nonfinite_count``)."""
    imu = "imu" if imu_view == "clean" else "imu_full"
    rows = [(float(r[0]), name, r[1:]) for name in (imu, "wheels", "steer", "cam", "currents")
            for r in getattr(obs, name)]
    rows.sort(key=lambda x: x[0] if math.isfinite(x[0]) else math.inf)   # stable
    return rows


#: IMU views of the AgriMaRo EKF (:class:`AgriMaRoVisualOdometryEKF`, ``imu``)
AGRIMARO_IMU_VIEWS: tuple[str, ...] = ("clean", "full", "full-averaged", "full-gyro")


class AgriMaRoVisualOdometryEKF:
    """Streaming AgriMaRo EKF (seed 001 ch. 6.1) on IMU, encoders, steering and camera.

    Parameters
    ----------
    accel_std_m_s2 : float
        Accelerometer noise for :func:`terrain.estimation.agrimaro.noise_derived_settings`,
        m/s^2 (its default 0.8: vibration included).
    imu : {"full-gyro", "clean", "full", "full-averaged"}
        IMU view (:data:`AGRIMARO_IMU_VIEWS`): ``clean`` the loop's IMU without the vibration
        band and gravity (the AgriMaRo's control figures before 2026-11-26); the others
        read the full IMU a robot logs: ``full`` its ``ax, ay, wz`` at every sample,
        ``full-averaged`` its gyro at every sample and the accelerometer rows once per block
        of ``accel_block_s`` as the block mean, with a noise variance measured online
        (:meth:`_full_imu_sample`), ``full-gyro`` its gyro only (the acceleration states
        are then observed only through the camera and the encoders; the default). On the
        simulated control grid's level cells the two last give the same speed error (0.015
        m/s, against 0.024 for ``full``) and the gyro alone the steadier acceleration; on
        every cell the robot can drive, sloped or level, the gyro view holds the slip limit
        as ``clean`` does (docs/control_validation.md, "The AgriMaRo's EKF on the full IMU").
    accel_block_s : float
        Block of the ``full-averaged`` view's accelerometer rows, s (> 0).
    adapt_blocks : int
        Blocks over which that view's noise variance is averaged (>= 2).
    speed_slope_s : float
        ``full-gyro`` view: the acceleration handed to the controller (``a_local_m_s2``,
        which selects its traction / steady / braking mode, eq. 8.6) is the least-squares
        slope of the estimated longitudinal speeds of the calls in the last
        ``speed_slope_s`` seconds, not the filter's acceleration state, s (> 0). Without an
        accelerometer that state is observed through the camera and the zero-slip wheel rows
        (eq. 6.6), and on soft ground the slipping wheels bias it (GRASS cruise at 0.875
        m/s: +0.14 m/s^2 mean, so the controller cruised in traction mode), whereas the
        speed itself is anchored by the camera (0.878 against 0.875 m/s). 0.5 s was the
        better of 0.5 and 1.0 s on a probe of 12 cells (TILES, GRASS, SNOW, ICE x
        straight_accel, orchard, random, seeds 0-2): mode agreement with the true
        acceleration 0.89 / 0.88 / 0.55 against 0.25 / 0.42 / 0.51 with the state
        (docs/control_validation.md, "The AgriMaRo's EKF on the full IMU").

    Raises
    ------
    ConfigError
        Another ``imu`` view; an accelerometer std, a block or a speed-slope window that is
        not a finite number > 0; ``adapt_blocks`` not an integer >= 2 (named).

    Notes
    -----
    A sample of a NaN or infinite time, or with such a value among those the view reads, is
    skipped (in part: a full-IMU sample's finite gyro is still used) and counted in
    ``nonfinite_count``.
    """

    name = "agrimaro-ekf-vo-full-gyro"
    limits = ("12-state EKF of seed 001 ch. 6.1 with the T265 velocity (rows v_cx, v_cy, "
              "yaw_rate_c; yaw_c and the IMU yaw left out); noise-derived tuning; without a "
              "camera sample the velocity drifts with the slipping wheels, so the estimate is "
              "reported stale (age = time since the last camera sample)")

    def __init__(self, accel_std_m_s2: float = 0.8, imu: str = "full-gyro",
                 accel_block_s: float = 0.1, adapt_blocks: int = 20,
                 speed_slope_s: float = 0.5) -> None:
        if imu not in AGRIMARO_IMU_VIEWS:
            raise ConfigError(f"imu must be one of {', '.join(AGRIMARO_IMU_VIEWS)} for the "
                              f"AgriMaRo EKF, got {imu!r}")
        # inf: a block that never closes (the accelerometer never read), a speed window that
        # keeps the whole run; 2.7 blocks were read as 2
        config_positive("AgriMaRoVisualOdometryEKF", accel_std_m_s2=accel_std_m_s2,
                        accel_block_s=accel_block_s, speed_slope_s=speed_slope_s)
        config_integer("AgriMaRoVisualOdometryEKF adapt_blocks", adapt_blocks, 2)
        self.speed_slope_s = float(speed_slope_s)
        # (t, v_long) of the calls within speed_slope_s (``full-gyro``)
        self._speeds: deque[tuple[float, np.ndarray]] = deque()
        self.imu = imu
        # "agrimaro-" and the estimator kind of this view (IMU_VIEW_OF_KIND, the one table)
        self.name = "agrimaro-" + next(kind for kind, view in IMU_VIEW_OF_KIND.items()
                                       if kind.startswith("ekf-vo") and view == imu)
        self.accel_std_m_s2 = float(accel_std_m_s2)
        self.accel_block_s = float(accel_block_s)
        # the accelerometer block being averaged: sum, count, start; the previous block mean
        self._block_sum = np.zeros(2)
        self._block_n = 0
        self._block_t0 = math.nan
        self._last_block_mean: np.ndarray | None = None
        # (M_k - M_k-1)^2 / 2 of the last blocks' means: variance of a block mean
        self._block_var: deque[np.ndarray] = deque(maxlen=int(adapt_blocks))
        #: accelerometer std of the last block mean used, m/s^2 (``full-averaged``)
        self.accel_block_std_m_s2 = np.full(2, math.nan)
        #: samples skipped, in whole or part, for a NaN or infinite value the filter reads
        self.nonfinite_count = 0
        self.vehicle = get_vehicle("agrimaro")
        self.model = AgriMaRoModel(self.vehicle, noise_derived_settings(
            accel_std_m_s2=accel_std_m_s2))
        m = self.model
        # the model's residual wraps the angle rows (the steering encoders read within one
        # turn)
        self.ekf = ExtendedKalmanFilter(m.x0, m.P0, m.f, m.F, m.h, m.H, m.Q, m.R_diag,
                                        residual=m.residual)
        # the filter's time: that of its first sample (None before), not 0 s: a log stamped
        # from 1000 s began with one prediction over 1000 s, one stamped before 0 s was never
        # predicted until its clock passed 0
        self.t: float | None = None
        self.t_cam = -math.inf
        self.omega = np.zeros(3)
        # the model's rows of each stream, less the yaw angles (yaw_imu, yaw_c) the loop
        # does not feed
        self.rows = MappingProxyType({stream: SENSOR_ROWS[sensor][:3] for stream, sensor in
                                      (("imu", "imu"), ("wheels", "omega"), ("steer", "steer"),
                                       ("cam", "cam"))})

    def update(self, obs: Observation) -> VelocityEstimate:
        """See :meth:`SlipEstimator.update`.

        Parameters
        ----------
        obs : Observation
            Samples since the previous call.

        Returns
        -------
        VelocityEstimate
        """
        for t, name, z in _merged(obs, self.imu):
            if not math.isfinite(t):   # unknown time: not placed in the filter's time line
                if name != "currents":   # (the currents are not read)
                    self.nonfinite_count += 1
                continue
            if self.t is None:
                self.t = t
            elif t > self.t:
                self.ekf.predict(t - self.t)
                self.t = t
            if name == "wheels" and np.all(np.isfinite(z)):   # a NaN one is skipped below
                self.omega = z.copy()
            if name == "imu_full":      # wx wy wz ax ay az
                if self.imu != "full":
                    self._full_imu_sample(t, z)
                    continue
                name, z = "imu", z[[3, 4, 2]]   # the model's ax, ay, wz
            z = z[:3]
            if name not in self.rows:
                continue
            if np.all(np.isfinite(z)):
                self.ekf.update(z, rows=self.rows[name])
                if name == "cam":   # only a sample the filter used renews the reference
                    self.t_cam = t
            else:
                self.nonfinite_count += 1
        x = self.ekf.x
        vx, vy, w, ax, ay = x[3], x[4], x[5], x[6], x[7]
        pos = np.asarray(self.vehicle.wheel_positions_m)
        d = x[8:11]
        v_long = wheel_rim_speed(vx, vy, w, pos[:, 0], pos[:, 1], d)   # eq. 4.20
        a_long = ax * np.cos(d) + ay * np.sin(d)
        if self.imu == "full-gyro":
            a_long = self._speed_slope(float(obs.t_s), v_long, a_long)
        return VelocityEstimate(self.omega.copy(), v_long, a_long, float(math.hypot(vx, vy)),
                                float(obs.t_s - self.t_cam))

    def _speed_slope(self, t: float, v_long: np.ndarray, a_state: np.ndarray) -> np.ndarray:
        """Least-squares slope of the estimated speeds of the last ``speed_slope_s``, m/s^2
        per unit (:func:`numpy.polyfit`, degree 1); ``a_state`` while fewer than three calls
        at two distinct times are in the window, and at a call of non-finite time (not
        added to the window). The window keeps the call exactly ``speed_slope_s`` back,
        within the clock's rounding (:func:`terrain.run.clock_slack`: the same calls on any
        clock's origin).

        Parameters
        ----------
        t : float
            Time of the call, s.
        v_long : ndarray, shape (3,)
            Estimated longitudinal ground speed of each unit at ``t``, m/s.
        a_state : ndarray, shape (3,)
            The filter's acceleration along each unit, m/s^2.

        Returns
        -------
        ndarray, shape (3,)
        """
        speeds = self._speeds
        if not math.isfinite(t):   # NaN stayed at the head for good: a LinAlgError at once
            return a_state
        speeds.append((t, np.asarray(v_long, dtype=float).copy()))
        # the call exactly speed_slope_s back stays, within the clock's rounding (1 ns alone:
        # on an epoch clock it was kept or dropped by the clock's origin)
        while speeds[0][0] < t - self.speed_slope_s - clock_slack(t):
            speeds.popleft()
        times = np.array([s[0] for s in speeds])
        if len(speeds) < 3 or times[0] == times[-1]:
            return a_state
        return np.polyfit(times - t, np.array([s[1] for s in speeds]), 1)[0]

    def _full_imu_sample(self, t: float, z: np.ndarray) -> None:
        """One full-IMU sample of the ``full-averaged`` or ``full-gyro`` view.

        The gyro row at once; with ``full-averaged`` the accelerometer rows once per block of
        ``accel_block_s``, as the block mean. The terrain's vibration band is coloured (a
        15 Hz first-order band in the simulator, :mod:`terrain.sim.sensors`) and its level
        follows the terrain and the speed, so no fixed white-noise std fits it. A block
        mean's noise is close to white at the block rate, and its variance is measured
        online without a noise model: the vehicle's own acceleration hardly changes from one
        block to the next, so ``(M_k - M_{k-1})^2 / 2`` of consecutive block means (the
        two-sample or Allan variance at the block length, IEEE Std 952-1997, annex C)
        estimates the variance of a block mean, whatever the noise's colour, as long as its
        correlation time is short against a block. It is averaged over the last
        ``adapt_blocks`` blocks (used from the second such difference on: one difference is
        no estimate) and floored at the white-noise variance of a block mean,
        ``accel_std_m_s2^2 / n`` (``n`` the block's samples; a block closes at the first
        sample ``accel_block_s`` after its first, within the clock's rounding
        (:func:`terrain.run.clock_slack`), so at 100 Hz a 0.1 s block holds 11 on any
        clock).

        Parameters
        ----------
        t : float
            Sample time, s.
        z : ndarray, shape (6,)
            ``wx, wy, wz, ax, ay, az`` (rad/s, m/s^2).
        """
        wz, a_xy = z[2], z[3:5]
        rows = self.rows["imu"]             # the model's ax, ay, wz rows
        accel_ok = self.imu == "full-gyro" or bool(np.all(np.isfinite(a_xy)))
        if math.isfinite(wz):
            self.ekf.update(np.array([wz]), rows=rows[2:3])
        if not (accel_ok and math.isfinite(wz)):
            self.nonfinite_count += 1
        if self.imu == "full-gyro" or not accel_ok:
            return
        if self._block_n == 0:
            self._block_t0 = t
        self._block_sum = self._block_sum + a_xy
        self._block_n += 1
        # (1 ns of slack alone: on an epoch clock the sample one block later fell short)
        if t - self._block_t0 < self.accel_block_s - clock_slack(t):
            return
        n, mean = self._block_n, self._block_sum / self._block_n
        self._block_sum, self._block_n = np.zeros(2), 0
        if self._last_block_mean is not None:
            self._block_var.append((mean - self._last_block_mean) ** 2 / 2.0)
        self._last_block_mean = mean
        r = np.full(2, self.accel_std_m_s2 ** 2 / n)
        if len(self._block_var) >= 2:
            r = np.maximum(r, np.mean(self._block_var, axis=0))
        self.ekf.update(mean, rows=rows[:2], R=r)
        self.accel_block_std_m_s2 = np.sqrt(r)


def check_callable(owner: str, **functions) -> None:
    """Raise a :class:`ConfigError` naming the first argument of ``functions`` that is
    neither callable nor None (a label, a number: a bare TypeError at the first call that
    used it); the check of the optional callbacks of the observers and the closed loop.

    Parameters
    ----------
    owner : str
        The refusing class or function, for the message.
    **functions
        Argument name -> a callable or None.

    Raises
    ------
    ConfigError
        "<owner>: <name> must be a function or None, got <type> <value>".
    """
    for name, f in functions.items():
        if f is not None and not callable(f):
            raise ConfigError(f"{owner}: {name} must be a function or None, got "
                              f"{type(f).__name__} {f!r:.60}")


def _skid_steer(owner: str, vehicle: str) -> HuskyParams | TrackedParams:
    """The catalogued skid-steer vehicle ``vehicle``; another one (the AgriMaRo: steered
    wheels, no track) stopped on a bare AttributeError about ``track_m``."""
    params = get_vehicle(vehicle)
    if not isinstance(params, (HuskyParams, TrackedParams)):
        raise ConfigError(f"{owner}: vehicle {vehicle!r} is not a skid-steer vehicle (husky, "
                          "tracked), whose two sides it estimates (the AgriMaRo's estimator: "
                          "AgriMaRoVisualOdometryEKF)")
    return params


class WheelImuObserver:
    """Interim skid-steer estimator: integrated accelerometer pulled to the slower side.

    ``v <- v + dt a_x`` at every IMU sample (``v``: the chassis centre's speed); at every
    encoder sample ``v <- v + (1 - exp(-dt_w / tau_s)) (v_ref - v)`` with ``v_ref`` the centre
    speed a side's wheel implies, ``omega_l r + yaw_rate B / 2`` (left) or
    ``omega_r r - yaw_rate B / 2`` (right), whichever has the smaller magnitude (the side that
    slips less while driving); side speeds ``v -/+ yaw_rate B / 2`` (gyro, track B, left
    first, yaw rate positive counter-clockwise). In a steady turn without slip both sides
    imply the true centre speed; pulling the centre to a side's own speed (as before
    2026-11-26) read the inner side's speed as the centre's (0.5 m/s, 0.5 rad/s on the Husky:
    side speeds 0.215 / 0.500 m/s against the true 0.357 / 0.643).

    Known error in turns (``limits``): the accelerometer reads ``a_x = dv_x/dt - yaw_rate v_y``
    and the observer integrates it as ``dv_x/dt``; a skid-steer vehicle slides outwards in a
    turn (``v_y`` of the other sign than the yaw rate), so the estimate runs high by about
    ``|yaw_rate v_y| tau_s`` (simulated Husky on TILES, ``random`` seed 0: 0.66 rad/s turn,
    ``v_y`` -0.145 m/s, estimate 0.757 against 0.612 m/s). The old pull to the inner side's
    speed happened to cancel most of it on that run (speed RMSE over 15 s 0.034 m/s, now
    0.086; straight runs unchanged).

    Parameters
    ----------
    vehicle : str
        Skid-steer vehicle name (wheel radius, track).
    tau_s : float
        Time constant of the pull towards the slower wheel, s (finite, > 0).

    Raises
    ------
    ConfigError
        ``tau_s`` not a finite number > 0 (inf would never pull to the wheels); an unknown
        vehicle or one that is not a skid-steer (``agrimaro``: no track).

    Notes
    -----
    An IMU or wheel sample holding a NaN or infinite time or value is skipped and counted in
    ``nonfinite_count``. A sample stamped before the latest of its stream (a late one) is
    read over no interval (no integration, no pull; the stream's time stays the latest).
    """

    name = "wheel-imu-observer"

    def __init__(self, vehicle: str = "husky", tau_s: float = 2.0) -> None:
        config_positive("WheelImuObserver", tau_s=tau_s)   # inf: never pulled to the wheels
        self.vehicle = _skid_steer("WheelImuObserver", vehicle)
        self.tau_s = float(tau_s)
        self.limits = (f"interim until the fused slip estimate: integrated accelerometer "
                       f"pulled to the centre speed the slower side's wheel implies "
                       f"(tau = {tau_s:g} s); a slip "
                       f"common to both sides is seen only for times short against tau, "
                       f"steady slip converges to 0 in the estimate; in turns the "
                       f"accelerometer's yaw_rate v_y term (outward slide) is integrated as "
                       f"acceleration and the estimate runs high")
        self.v = 0.0
        self.a = 0.0
        self.w = 0.0
        self.t_imu: float | None = None
        self.t_wheel: float | None = None
        self.omega = np.zeros(2)
        #: IMU and wheel samples skipped for a NaN or infinite value
        self.nonfinite_count = 0

    def update(self, obs: Observation) -> VelocityEstimate:
        """See :meth:`SlipEstimator.update`.

        Parameters
        ----------
        obs : Observation
            Samples since the previous call.

        Returns
        -------
        VelocityEstimate
        """
        r = self.vehicle.wheel_radius_m
        for t, name, z in _merged(obs):
            if name not in ("imu", "wheels"):
                continue
            if not (math.isfinite(t) and np.all(np.isfinite(z))):
                self.nonfinite_count += 1
                continue
            if name == "imu":
                # a late sample (stamped before the latest) integrates over no interval:
                # over its negative one a forward acceleration slowed the robot
                if self.t_imu is not None and t > self.t_imu:
                    self.v += (t - self.t_imu) * float(z[0])
                self.t_imu = t if self.t_imu is None else max(self.t_imu, t)
                self.a, self.w = float(z[0]), float(z[2])
            else:
                self.omega = z.copy()
                # centre speed each side implies (left + B w / 2, right - B w / 2)
                half_w = 0.5 * self.vehicle.track_m * self.w
                centre = z[:2] * r + np.array([half_w, -half_w])
                v_ref = float(centre[np.argmin(np.abs(centre))])
                # a late sample pulls over no interval: 1 - exp(|dt| / tau) < 0 pushed away
                dt_w = 0.0 if self.t_wheel is None else max(t - self.t_wheel, 0.0)
                self.v += (1.0 - math.exp(-dt_w / self.tau_s)) * (v_ref - self.v)
                if np.all(z == 0.0) and np.all(obs.omega_low_level == 0.0):
                    self.v = 0.0                      # standing still: zero-velocity update
                self.t_wheel = t if self.t_wheel is None else max(self.t_wheel, t)
        half = 0.5 * self.vehicle.track_m * self.w
        age = math.inf if self.t_wheel is None else float(obs.t_s - self.t_wheel)
        return VelocityEstimate(self.omega.copy(), np.array([self.v - half, self.v + half]),
                                np.array([self.a, self.a]), abs(self.v), age)


#: Fusion settings of the online adaptor: issue 10's defaults (:class:`FusionSettings`) with
#: the slip random-walk density raised from 6e-6 to 0.01 1/s. Replayed open-loop Husky runs
#: (``straight_accel``, seed 0, 8 s, steady part t > 3 s, docs/control_validation.md): with
#: 6e-6 the slip state needs tens of seconds to follow the 0.2 s pseudo-measurements (steady
#: slip RMSE 0.126 on SNOW, 0.032 on SANDY_LOAM); with 0.01 it is 0.003-0.004 on both and
#: unchanged (0.001-0.002) on ICE and TILES; 0.1 and 1.0 give no further steady gain.
CONTROL_FUSION = FusionSettings(filter=SkidSteerSlipSettings(slip_psd=0.01))

#: What the fused observer reads of the IMU (:class:`FusedSlipObserver`, ``imu``): ``clean``
#: the loop's simplified IMU (``Observation.imu``: no vibration band, no gravity) with its
#: gyro and ``ax`` rows; ``full`` the full IMU (``Observation.imu_full``, what a robot
#: logs) with its gyro and the ``ax, az`` rows; ``full-gyro`` (the default) the full IMU's
#: gyro only
IMU_VIEWS: tuple[str, ...] = ("clean", "full", "full-gyro")


class FusedSlipObserver:
    """Online adaptor of the fused slip estimate of issue 10 (the Husky's slip estimator).

    The slip-learning work ships the fused estimate as a batch function over a whole run
    (:func:`terrain.slip.estimate.estimate_skid_steer_slip_run`); this adaptor runs the same
    pieces sample by sample, calling each where it is defined:

    * the filter: the 8-state slip-augmented skid-steer EKF
      :class:`terrain.estimation.skid_steer_slip.SkidSteerSlipModel` with the tuning of
      :class:`terrain.slip.estimate.FusionSettings` (``filter``, track of the vehicle),
      stepped with :func:`terrain.estimation.ekf.predict` / :func:`~terrain.estimation.ekf.correct`
      at every sample: wheel rows ``vel_l, vel_r`` (encoder speed times the radius), gyro
      row ``wz``, and with ``imu`` ``full`` or ``clean`` the accelerometer rows (``ax, az``
      of the full IMU, or ``ax`` of the loop's simplified IMU, which has no ``az``: the pitch
      state is then observed only through ``ax`` and the wheels; with the gyro alone the
      acceleration and pitch states are not observed and the speed follows the wheels and
      the pseudo-measurements);
    * the pseudo-measurement of the side slips: the physics slip
      (:func:`terrain.slip.physics.physics_slip`: motor current -> torque -> traction ->
      stable-side inverse of the decided terrain's curve) of the last ``window_s`` of
      current and wheel samples (those at or after ``t - window_s``, the sample exactly
      ``window_s`` back included), every ``period_s`` (within the clock's rounding,
      :func:`terrain.run.clock_slack`: on any clock's origin at the same calls), with its
      std floored by :func:`terrain.slip.estimate.pseudo_measurement`; the terrain is the
      loop's decision
      (no pseudo-measurement without a catalogued decision);
    * the controller's inputs: each side's ground speed implied by the measured wheel speed
      and the estimated slip through the model's wheel row
      (:func:`terrain.terramechanics.slip.ground_speed_from_slip`, ``omega_i r (1 - s_i)`` in
      traction), so the controller regulates the filter's slip state; the
      acceleration ``a_x``; the chassis speed ``|v_bx|``; and the estimate's age ``age_s``
      (s): the *larger* of the latest wheel sample's age and the time since the last
      pseudo-measurement the filter used (a finite one) less ``period_s``, inf before the
      first wheel sample or the first used pseudo-measurement (so always without a
      catalogued terrain decision). Without its slip model the slip common to both sides is
      not observable and the filter drifts, so the age grows once no pseudo-measurement was
      used for ``period_s``; the controller's safe output applies when the age exceeds its
      ``max_input_age_s``, i.e. after ``period_s + max_input_age_s`` without one (Husky:
      0.2 + 0.25 s);
    * the speed bound of the batch estimate (``settings.filter.speed_bound_braking_slip``,
      ``speed_bound_hold_s``): after every sample the estimate is projected in its
      covariance's metric (:func:`terrain.estimation.ekf.project_to_bounds`) into the
      forward-speed range that the wheel samples of the last ``speed_bound_hold_s`` allow
      (:func:`terrain.estimation.skid_steer_slip.rim_speed_range_m_s`, each rim widened by
      :data:`~terrain.estimation.skid_steer_slip.SPEED_BOUND_NOISE_STDS` times the wheel
      noise), moving only the speed and the slips
      (:data:`~terrain.estimation.skid_steer_slip.SPEED_BOUND_STATES`); ``bound_count``
      counts the projected samples.

    A sample holding a NaN or infinite time or value is skipped and counted in
    ``nonfinite_count`` (as are those of :class:`AgriMaRoVisualOdometryEKF` and
    :class:`WheelImuObserver`; ``estimator_nonfinite_samples`` of the closed loop's metrics).

    Differences from the batch estimate (``limits``): causal windows (the batch centres a
    2 s window on the estimate, i.e. uses 1 s of future data), no learned model (the
    registered one is trained on 2 s windows), no lag estimation.

    Parameters
    ----------
    vehicle : str
        Skid-steer vehicle name.
    terrain_decision : callable, optional
        ``f(t_s) -> (label or None, confidence, ...)``, the loop's terrain decision (its
        label is used); None: no pseudo-measurement.
    window_s : float
        Length of the current / wheel window of one physics slip, s (finite, > 0).
    period_s : float
        Interval between pseudo-measurements, s (finite, > 0).
    settings : FusionSettings
        Std floors and EKF tuning (:data:`CONTROL_FUSION`: issue 10's defaults with a
        faster slip random walk).
    physics_settings : PhysicsSlipSettings
        Uncertainties of the physics slip.
    imu : str
        What it reads of the IMU, one of :data:`IMU_VIEWS`: default ``full-gyro``, the gyro
        of the IMU a robot has (docs/control_validation.md, "The Husky's observer on the
        full IMU": its accelerometer rows would take the terrain's vibration for
        acceleration); ``clean`` the view of the control figures before 2026-11-26.

    Raises
    ------
    ConfigError
        A window or period that is not a finite number > 0; an unknown ``imu`` view; an
        unknown vehicle or one that is not a skid-steer (``agrimaro``); a
        ``terrain_decision`` that is neither callable nor None (named).
    """

    def __init__(self, vehicle: str = "husky",
                 terrain_decision: Callable[[float], tuple] | None = None,
                 window_s: float = 0.5, period_s: float = 0.2,
                 settings: FusionSettings = CONTROL_FUSION,
                 physics_settings: PhysicsSlipSettings = PhysicsSlipSettings(),
                 imu: str = "full-gyro") -> None:
        # inf: a window that keeps every sample, a period that never gives a pseudo-measurement
        config_positive("FusedSlipObserver", window_s=window_s, period_s=period_s)
        check_callable("FusedSlipObserver", terrain_decision=terrain_decision)
        if imu not in IMU_VIEWS:
            raise ConfigError(f"imu must be one of {', '.join(IMU_VIEWS)}, got {imu!r}")
        self.imu = imu
        self.name = "husky-fused-slip-ekf" + ("" if imu == "full-gyro" else f"-{imu}-imu")
        self.vehicle = _skid_steer("FusedSlipObserver", vehicle)
        self.settings = settings
        self.physics_settings = physics_settings
        self.model = SkidSteerSlipModel(replace(settings.filter, track_m=self.vehicle.track_m))
        self.x = self.model.x0.copy()
        self.P = self.model.P0.copy()
        self.r_diag = self.model.R_diag
        self.terrain_decision = terrain_decision
        self.window_s, self.period_s = float(window_s), float(period_s)
        braking = settings.filter.speed_bound_braking_slip
        bound = ("no speed bound" if braking is None else
                 f"forward speed held within what the wheel samples of the last "
                 f"{settings.filter.speed_bound_hold_s:g} s allow (braking slip down to "
                 f"{braking:+.2f})")
        rows_used = {"clean": "gyro, ax of the loop's IMU without vibration and gravity",
                     "full": "gyro, ax, az of the full (vibrating) IMU",
                     "full-gyro": "gyro of the full (vibrating) IMU, no accelerometer"}[imu]
        self.limits = (f"fused slip EKF of issue 10 run online (adaptor): wheels, {rows_used}; "
                       f"physics-slip pseudo-measurement from motor currents over causal "
                       f"{window_s:g} s windows every {period_s:g} s under the loop's terrain "
                       f"decision; {bound}; no learned model, no lag estimation")
        self.t: float | None = None
        self.t_wheel: float | None = None
        self.t_pseudo = -math.inf
        self.t_pseudo_ok = -math.inf
        self.omega = np.zeros(2)
        self.wheel_rows: list[np.ndarray] = []
        self.current_rows: list[np.ndarray] = []
        self.pseudo_count = 0
        # speed bound: (t, lower, upper) of the wheel samples that can still hold it
        self.bound_rows: list[tuple[float, float, float]] = []
        self.bound_count = 0
        #: samples skipped for a NaN or infinite value
        self.nonfinite_count = 0
        self._v = STATE_NAMES.index("v_bx")

    def _correct(self, z: np.ndarray, rows: tuple[int, ...], r_diag: np.ndarray) -> None:
        idx = list(rows)
        hx, h_jac = self.model.observation(self.x)
        self.x, self.P, _ = correct(self.x, self.P, np.asarray(z, float) - hx[idx],
                                    h_jac[idx], np.asarray(r_diag, float), check=False)

    def _bound_speed(self, t: float) -> None:
        """Project the estimate into the speed range the recent wheel samples allow."""
        if not self.bound_rows:   # no wheel sample yet, or no bound (braking slip None)
            return
        # the range of a wheel sample holds until the next one; each end is held at its widest
        # over the last hold_s: every sample after t - hold_s and the one current then
        # (within the clock's rounding: a sample exactly hold_s back is the one current then,
        # and the one before it no longer counts)
        start = t - self.settings.filter.speed_bound_hold_s + clock_slack(t)
        first = max((i for i, row in enumerate(self.bound_rows) if row[0] <= start),
                    default=0)
        self.bound_rows = self.bound_rows[first:]
        lo = min(row[1] for row in self.bound_rows)
        up = max(row[2] for row in self.bound_rows)
        v = float(self.x[self._v])
        if lo <= v <= up:
            return
        lower = np.full(self.x.size, -np.inf)
        upper = np.full(self.x.size, np.inf)
        lower[self._v], upper[self._v] = lo, up
        self.x, _ = project_to_bounds(self.x, self.P, lower, upper, SPEED_BOUND_MOVABLE)
        self.bound_count += 1

    def _pseudo(self, t: float) -> None:
        label = self.terrain_decision(t)[0] if self.terrain_decision else None
        if label is None or str(label).upper() not in TERRAIN_NAMES:
            return
        # at or after t - window_s within the clock's rounding: the sample exactly window_s
        # back was in or out by the rounding of t - window_s (25 or 26 at 50 Hz)
        t0 = t - self.window_s - clock_slack(t)
        cur = np.array([c for c in self.current_rows if c[0] >= t0])
        wheels = np.array([w for w in self.wheel_rows if w[0] >= t0])
        if len(cur) == 0 or len(wheels) == 0:
            return
        r = self.vehicle.wheel_radius_m
        rim = wheels[:, 1:].mean(axis=0) * r
        span = wheels[-1, 0] - wheels[0, 0]
        acc = ((wheels[-1, 1:] - wheels[0, 1:]) / span) if span > 0 else np.zeros(2)
        phys = physics_slip(self.vehicle, {str(label).upper(): 1.0},
                            cur[:, 1:].mean(axis=0)[None], rim[None],
                            np.array([self.x[7]]), acc[None], n_averaged=float(len(cur)),
                            settings=self.physics_settings)
        _, slip, std = pseudo_measurement({"physics": (np.array([t]), phys.slip, phys.std)},
                                          "physics", self.settings)
        if np.all(np.isfinite(slip)) and np.all(np.isfinite(std)):
            self._correct(slip[0], SLIP_SENSOR_ROWS["slip_model"], std[0] ** 2)
            self.pseudo_count += 1
            self.t_pseudo_ok = t
        self.t_pseudo = t

    def update(self, obs: Observation) -> VelocityEstimate:
        """See :meth:`SlipEstimator.update`.

        Parameters
        ----------
        obs : Observation
            Samples since the previous call.

        Returns
        -------
        VelocityEstimate
        """
        r = self.vehicle.wheel_radius_m
        rows = SLIP_SENSOR_ROWS
        for t, name, z in _merged(obs, self.imu):
            if not math.isfinite(t):   # unknown time: inf made the filter's time inf for good
                self.nonfinite_count += 1
                continue
            if self.t is not None and t > self.t:
                self.x, self.P = predict(self.x, self.P, t - self.t, self.model.f,
                                         self.model.F, self.model.Q, check=False)
            self.t = t if self.t is None else max(self.t, t)
            if not np.all(np.isfinite(z)):
                self.nonfinite_count += 1
                continue
            if name == "imu":
                self._correct(z[[2]], rows["gyro"], self.r_diag[list(rows["gyro"])])
                self._correct(z[[0]], rows["accel"][:1], self.r_diag[[rows["accel"][0]]])
            elif name == "imu_full":    # wx wy wz ax ay az: the vibrating IMU
                self._correct(z[[2]], rows["gyro"], self.r_diag[list(rows["gyro"])])
                if self.imu == "full":
                    self._correct(z[[3, 5]], rows["accel"], self.r_diag[list(rows["accel"])])
            elif name == "wheels":
                self.omega = z.copy()
                self.t_wheel = t
                self.wheel_rows.append(np.concatenate([[t], z]))
                self._correct(z * r, rows["wheels"], self.r_diag[list(rows["wheels"])])
                braking = self.settings.filter.speed_bound_braking_slip
                if braking is not None:
                    lo, up = rim_speed_range_m_s(
                        z * r, braking, self.settings.filter.speed_bound_rim_margin_m_s)
                    self.bound_rows.append((t, float(lo[0]), float(up[0])))
            elif name == "currents":
                self.current_rows.append(np.concatenate([[t], z]))
            self._bound_speed(t)
        keep = obs.t_s - self.window_s - 1.0
        self.wheel_rows = [w for w in self.wheel_rows if w[0] >= keep]
        self.current_rows = [c for c in self.current_rows if c[0] >= keep]
        # one period later within the clock's rounding (1 ns alone skipped such a call on an
        # epoch clock: 0.22 s between pseudo-measurements)
        if self.current_rows and obs.t_s - self.t_pseudo >= self.period_s - clock_slack(obs.t_s):
            self._pseudo(obs.t_s)
            self._bound_speed(obs.t_s)
        # the ground speed the measured wheel speed and the estimated slip imply, through the
        # model's own wheel row (rim_speed_from_slip): the controller's slip is the state's
        slip = np.clip(self.x[4:6], -MAX_SLIP, MAX_SLIP)
        ground = ground_speed_from_slip(self.omega * r, slip)
        age = math.inf if self.t_wheel is None else float(obs.t_s - self.t_wheel)
        # without its slip model the common slip is unobservable: stale with no recent one
        age = max(age, float(obs.t_s - self.t_pseudo_ok) - self.period_s)
        return VelocityEstimate(self.omega.copy(), ground, np.full(2, self.x[6]),
                                abs(float(self.x[0])), age)


#: Estimators of :func:`estimator_for` per vehicle; the first is the default (the one the
#: vehicle would really have, issue 11).
ESTIMATORS: Mapping[str, tuple[str, ...]] = MappingProxyType({
    "agrimaro": ("ekf-vo-full-gyro", "ekf-vo", "ekf-vo-full-imu", "ekf-vo-full-imu-averaged"),
    "husky": ("fused", "observer", "fused-full-imu", "fused-clean-imu")})


#: IMU view (:data:`IMU_VIEWS`) of each estimator kind that has one
IMU_VIEW_OF_KIND: Mapping[str, str] = MappingProxyType({
    "ekf-vo": "clean", "ekf-vo-full-imu": "full", "ekf-vo-full-imu-averaged": "full-averaged",
    "ekf-vo-full-gyro": "full-gyro",
    "fused": "full-gyro",
    "fused-full-imu": "full", "fused-clean-imu": "clean"})


def estimator_for(vehicle: str, terrain_decision: Callable[[float], tuple] | None = None,
                  kind: str | None = None) -> SlipEstimator:
    """The estimator of a vehicle in the closed loop.

    Parameters
    ----------
    vehicle : str
        ``agrimaro`` or ``husky``.
    terrain_decision : callable, optional
        ``f(t_s) -> (label, confidence)``: the loop's terrain decision (the Husky's fused
        estimator needs the terrain's curve for its physics slip).
    kind : str, optional
        One of :data:`ESTIMATORS` of the vehicle: AgriMaRo ``ekf-vo-full-gyro``
        (:class:`AgriMaRoVisualOdometryEKF` on the gyro of the full IMU a robot logs; ``ekf-vo``
        on the loop's simplified IMU without vibration and gravity, the control figures before
        2026-11-26; on the full IMU ``ekf-vo-full-imu`` with every sample's accelerometer rows,
        ``ekf-vo-full-imu-averaged`` with block means and their measured noise); Husky
        ``fused`` (:class:`FusedSlipObserver`, issue 10's fused slip estimate on the gyro of
        the full IMU), ``observer`` (:class:`WheelImuObserver`, the earlier interim
        estimator, kept for comparison),
        ``fused-full-imu`` (the fused estimate with the full IMU's accelerometer rows too:
        ``imu`` ``full``) and ``fused-clean-imu`` (on the loop's IMU without vibration and
        gravity, ``imu`` ``clean``: the control figures before 2026-11-26). None: the first
        (default).

    Returns
    -------
    SlipEstimator

    Raises
    ------
    ConfigError
        Another vehicle (text or not), or a kind not available for it.
    """
    if not isinstance(vehicle, str) or vehicle not in ESTIMATORS:   # a list: unhashable
        raise ConfigError(f"no closed-loop estimator for vehicle {vehicle!r}; valid: "
                          f"{', '.join(ESTIMATORS)}")
    kind = kind or ESTIMATORS[vehicle][0]
    if kind not in ESTIMATORS[vehicle]:
        raise ConfigError(f"estimator {kind!r} not available for {vehicle}; valid: "
                          f"{', '.join(ESTIMATORS[vehicle])}")
    if kind == "observer":
        return WheelImuObserver(vehicle)
    if kind.startswith("ekf-vo"):
        return AgriMaRoVisualOdometryEKF(imu=IMU_VIEW_OF_KIND[kind])
    return FusedSlipObserver(vehicle, terrain_decision, imu=IMU_VIEW_OF_KIND[kind])
