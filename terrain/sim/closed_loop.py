"""Closed loop in simulation: online sensors between the plant and a robot-side controller.

:func:`terrain.sim.dynamics.integrate` hands its hook the *plant* at every time stamp
(:class:`~terrain.sim.dynamics.PlantSnapshot`: at rest at the first, then after every step).
:class:`OnlineSensors` turns that into what the robot measures, sample by sample at each
sensor's rate (the vehicle's :class:`~terrain.sim.sensors.SensorSettings`): the IMU, encoder
wheel speeds (count rate per physics step when the speed quantum is 0, the motor driver's
first-order filter, the speed quantum), motor currents, steering encoders quantised, and on
the AgriMaRo the T265 camera velocity at its mount with noise and outages. :func:`make_hook`
calls a controller at its own rate with only the samples taken since its previous call
(:class:`Observation`) and the robot's own low-level command, and returns its correction.

The IMU comes in two views of the same samples (same white noise and bias draws):

* ``imu_full`` (``wx, wy, wz, ax, ay, az``): the batch model's IMU
  (:func:`terrain.sim.sensors.imu`) generated online with the same functions: terrain
  vibration band (:func:`~terrain.sim.sensors.coloured_noise` with its filter state carried
  from sample to sample, :func:`~terrain.sim.sensors.vibration_level` from the plant's
  speed, :func:`~terrain.sim.sensors.vibration_signals` of the terrain under the vehicle),
  gravity on slopes (:func:`~terrain.sim.sensors.gravity_specific_force`), bias and white
  noise. The live terrain classifier reads it (it was trained on batch runs).
* ``imu`` (``ax, ay, wz``): the same samples with the vibration band and gravity left out,
  what the AgriMaRo's EKF and the Husky's interim observer read (a simplification: a real
  robot's estimators would read the vibrating IMU). The Husky's fused observer reads the
  gyro of ``imu_full`` (:data:`terrain.control.estimators.IMU_VIEWS`).

Other simplifications against the batch sensor model of :mod:`terrain.sim.simulate` (which
still writes the run's logged streams from the physics): no sensor lag, no planted effects;
noise from generators of their own (seeded from the run's seed), so the logged streams keep
the open-loop run's noise draws. The camera outages the controller sees are drawn there too,
so they differ from the logged streams' (metadata ``cam_outages_s``): a closed-loop run's
metadata lists them as ``controller_cam_outages_s`` (``[start, end)``, s) and counts the
camera rows they removed, ``controller_cam_rows_dropped`` (:func:`simulate_closed_loop`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace
from typing import Callable, NamedTuple, Sequence

import numpy as np

from terrain.errors import ConfigError, config_positive, config_seed
from terrain.sim.dynamics import ControlHook, PlantSnapshot
from terrain.sim.forces import check_physics, reported_current_a
from terrain.sim.sensors import (SensorSettings, coloured_noise, gravity_specific_force,
                                 quantise, steering_encoder, vibration_level, vibration_pole,
                                 vibration_signals)
from terrain.sim.simulate import (DEFAULT_SENSORS, SimConfig, Simulation, is_name_sequence,
                                  simulate_with_physics)
from terrain.terramechanics.catalogue import get_terrain
from terrain.vehicles import get_vehicle, point_velocity

__all__ = ["Observation", "OnlineSensors", "make_hook", "replay_observations",
           "simulate_closed_loop"]


class Observation(NamedTuple):
    """Sensor samples taken since the controller's previous call (rows in time order).

    Parameters
    ----------
    t_s : float
        Time of the call, s.
    omega_low_level : ndarray, shape (m,)
        The low-level wheel speed command the robot is about to apply, rad/s.
    imu : ndarray, shape (k, 4)
        ``t_s, ax, ay, wz`` (s, m/s^2, m/s^2, rad/s): ``imu_full`` without the vibration band
        and gravity (see the module docstring).
    wheels : ndarray, shape (k, 1 + m)
        ``t_s, omega_1..m`` encoder wheel speeds, rad/s (skid-steer: left, right).
    steer : ndarray, shape (k, 1 + m)
        ``t_s, delta_1..m`` steering encoders, rad (empty for skid-steer).
    cam : ndarray, shape (k, 5)
        ``t_s, v_cx, v_cy, yaw_rate_c, yaw_c`` camera (empty without a camera or in outages).
    currents : ndarray, shape (k, 1 + m)
        ``t_s, I_1..m`` motor current magnitudes as the drive reports them, A, at the wheel
        rate (from the snapshot's wheel torque, see :class:`OnlineSensors`).
    imu_full : ndarray, shape (k, 7)
        ``t_s, wx, wy, wz, ax, ay, az`` (s, rad/s, m/s^2): the IMU as the batch model writes
        it (terrain vibration, gravity), same sample times as ``imu``.
    """

    t_s: float
    omega_low_level: np.ndarray
    imu: np.ndarray
    wheels: np.ndarray
    steer: np.ndarray
    cam: np.ndarray
    currents: np.ndarray
    imu_full: np.ndarray


#: Tolerance of a sample or call time against its physics step, s (rounding of the grid)
SCHEDULE_TOLERANCE_S = 1e-9


def _schedule_tolerance(t_s: float) -> float:
    """Tolerance of a schedule at clock time ``t_s``: :data:`SCHEDULE_TOLERANCE_S`, or two
    units in the last place of ``t_s`` on a clock so far from 0 that it stores its times
    more coarsely (an epoch clock, 1.7e9 s: 2.4e-7 s), s."""
    return max(SCHEDULE_TOLERANCE_S, 2.0 * math.ulp(float(t_s)))


@dataclass
class _Channel:
    """A sensor's samples: due at ``n period_s`` after the run's first time (the product, not
    a running sum of periods,
    whose rounding drifted past :data:`SCHEDULE_TOLERANCE_S` after ~2170 s at 100 Hz and
    lost a sample), the rows taken since the controller's last call."""

    period_s: float
    next_t: float
    rows: list
    taken: int = 0

    def due(self, t_s: float, tolerance_s: float = SCHEDULE_TOLERANCE_S) -> bool:
        """Whether a sample is due at ``t_s`` (within ``tolerance_s``); if so, count it and
        schedule the next."""
        if t_s + tolerance_s < self.next_t:
            return False
        self.taken += 1
        self.next_t = self.taken * self.period_s
        return True


class OnlineSensors:
    """Sample the plant as the robot's sensors would, one physics step at a time.

    Parameters
    ----------
    vehicle : str
        Catalogued vehicle name (camera lever arm, encoder resolution, wheel radius).
    sensors : SensorSettings
        Rates, noise levels and quanta.
    seed : int
        Seed of the sensors' own generator (>= 0).
    duration_s : float
        Run length, s (for the camera outages, drawn at start as in the batch model).
    physics : str
        Physics version of the run (the current report of
        :func:`terrain.sim.forces.reported_current_a`).
    terrains : sequence of str
        Terrains of the run, indexed by the snapshot's ``terrain_index`` (their catalogue
        vibration levels shake ``imu_full``); empty: no vibration band.

    Notes
    -----
    Motor currents are sampled at the wheel rate from the snapshot's wheel torque with the
    drive's report (:func:`terrain.sim.forces.reported_current_a`), white noise
    ``current_noise_a`` and the quantum ``current_quantum_a`` (the planted current effects
    of the batch model are not applied). The IMU's vibration, ``wx, wy, az`` noise and the
    ``az`` bias come from a third generator, so the other draws are those of the IMU without
    them. The camera outages (``outages``, ``[start, end)`` pairs, s) are drawn at start
    from the sensors' own generator; ``cam_rows_dropped`` counts the camera samples they
    removed so far.

    Raises
    ------
    ConfigError
        Unknown vehicle, terrain or physics version, a seed that is not an integer >= 0,
        a duration that is not finite and > 0, ``sensors`` not :class:`SensorSettings`, or
        ``terrains`` not a sequence of names (one string, bytes, a number).
    """

    def __init__(self, vehicle: str, sensors: SensorSettings, seed: int,
                 duration_s: float, physics: str = "v1", terrains: Sequence[str] = ()) -> None:
        config_seed("OnlineSensors.seed", seed)     # SimConfig's rule
        config_positive("OnlineSensors", duration_s=duration_s)
        if not isinstance(sensors, SensorSettings):
            raise ConfigError(f"OnlineSensors.sensors must be SensorSettings (the vehicle's "
                              f"defaults: terrain.sim.DEFAULT_SENSORS), got "
                              f"{type(sensors).__name__}")
        if isinstance(terrains, str):
            raise ConfigError(f"OnlineSensors.terrains must be a sequence of terrain names, "
                              f"got the string {terrains!r}")
        if not is_name_sequence(terrains):
            # 5 was a bare TypeError (not iterable), b"ASPHALT" "unknown terrain 65"
            raise ConfigError(f"OnlineSensors.terrains must be a sequence of terrain names, "
                              f"got {type(terrains).__name__} {terrains!r:.60}")
        self.vehicle = get_vehicle(vehicle)
        check_physics(physics)   # here, not at the first current sample of the run
        self.physics = physics
        self.settings = sensors
        self.steered = self.vehicle.contact_geometry().steered
        self.rng = np.random.default_rng([int(seed), 11])
        s = sensors
        self.accel_bias = s.accel_bias_std_m_s2 * self.rng.standard_normal(2)
        self.ch = {"imu": _Channel(1.0 / s.imu_rate_hz, 0.0, []),
                   "wheels": _Channel(1.0 / s.wheel_rate_hz, 0.0, []),
                   "steer": _Channel(1.0 / s.steer_rate_hz, 0.0, []),
                   "cam": _Channel(1.0 / s.cam_rate_hz, 0.0, []),
                   "currents": _Channel(1.0 / s.wheel_rate_hz, 0.0, [])}
        # own generator for the currents: adding them leaves every other draw unchanged
        self.rng_current = np.random.default_rng([int(seed), 12])
        # and one for the full IMU's vibration band, its wx, wy, az noise and az bias
        self.rng_imu = np.random.default_rng([int(seed), 13])
        self.terrains = tuple(get_terrain(t) for t in terrains)
        self.vib_pole = vibration_pole(s.imu_rate_hz, s.vibration_bandwidth_hz)
        self.vib_state: np.ndarray | None = None
        self.accel_bias_z = s.accel_bias_std_m_s2 * self.rng_imu.standard_normal()
        self.imu_full_rows: list = []
        n_out = self.rng.poisson(s.cam_outage_rate_hz * duration_s)
        self.outages = [(a, a + b) for a, b in zip(self.rng.uniform(0, duration_s, n_out),
                                                   self.rng.uniform(0.5, 2.0, n_out))]
        self.cam_rows_dropped = 0       # camera samples the outages removed
        self._angle = 0.0
        self._counts = 0.0
        self._omega_prev = 0.0
        self._filtered: np.ndarray | None = None
        self._t_prev: float | None = None
        # the run's first time: the schedules and outages count from it (a grid that does
        # not start at 0 sampled every step until n period caught up with its clock)
        self._t0: float | None = None

    def record(self, snap: PlantSnapshot) -> None:
        """Take the samples due at ``snap.t_s``.

        Sample ``n`` of a sensor is due ``n`` periods after the first snapshot's time, and
        the camera outages are placed from that time on (the run's clock need not start at
        0; rows keep the snapshot's own time).

        Parameters
        ----------
        snap : PlantSnapshot
            Plant state at a time stamp of the physics grid.
        """
        s, t = self.settings, snap.t_s
        first = self._t_prev is None
        dt = 0.0 if first else t - self._t_prev
        self._t_prev = t
        if self._t0 is None:
            self._t0 = t
        t_run = t - self._t0            # (t itself on a clock from 0)
        tol = _schedule_tolerance(t)
        c = self.ch["imu"]
        if c.due(t_run, tol):
            n = self.rng.standard_normal(3)
            a = snap.accel_body + self.accel_bias + s.accel_noise_m_s2 * n[:2]
            wz = snap.twist[2] + s.gyro_noise_rad_s * n[2]
            c.rows.append((t, a[0], a[1], wz))
            self.imu_full_rows.append((t, *self._full_imu(snap, a, wz)))
        # encoders: count rate per physics step when the speed quantum is 0, then the motor
        # driver's first-order filter, sampled at the wheel rate (as the batch model,
        # encoder_count_rate: at the first step no count has changed yet, so its rate is 0
        # however fast the wheel already turns, and the filter starts there)
        motor = self.vehicle.motor
        if s.speed_quantum_m_s == 0 and first:
            raw = np.zeros_like(np.asarray(snap.omega, dtype=float))
        elif s.speed_quantum_m_s == 0 and dt > 0:
            self._angle = self._angle + 0.5 * dt * (snap.omega + self._omega_prev)
            q = motor.encoder_quantum_rad
            counts = np.floor(self._angle / q)
            raw = (counts - self._counts) * q / dt
            self._counts = counts
        else:
            raw = snap.omega
        if self._filtered is None:
            self._filtered = raw.copy()
        elif motor.encoder_filter_s > 0 and dt > 0:
            a = math.exp(-dt / motor.encoder_filter_s)
            self._filtered = a * self._filtered + (1 - a) * raw
        else:
            self._filtered = raw
        self._omega_prev = snap.omega
        c = self.ch["wheels"]
        if c.due(t_run, tol):
            r = self.vehicle.wheel_radius_m
            om = self._filtered
            if s.speed_quantum_m_s > 0:
                om = quantise(om * r, s.speed_quantum_m_s) / r
            c.rows.append((t, *om.tolist()))
        c = self.ch["currents"]
        if c.due(t_run, tol):
            cur = reported_current_a(motor, np.asarray(snap.torque, dtype=float), snap.omega,
                                     self.physics)
            cur = np.abs(cur + s.current_noise_a * self.rng_current.standard_normal(cur.size))
            cur = quantise(cur, s.current_quantum_a)
            c.rows.append((t, *cur.tolist()))
        if not self.steered:
            return
        c = self.ch["steer"]
        if c.due(t_run, tol):
            # absolute encoders, within one turn (a resolution of 0 is no quantisation, as
            # in the batch model)
            d = steering_encoder(snap.delta, s.steer_quantum_rad)
            c.rows.append((t, *d.tolist()))
        c = self.ch["cam"]
        if c.due(t_run, tol):
            if any(a <= t_run < b for a, b in self.outages):
                self.cam_rows_dropped += 1
            else:
                lever = self.vehicle.camera_lever_arm_m
                vx, vy, w = snap.twist.tolist()
                v_cx, v_cy = point_velocity(vx, vy, w, lever[0], lever[1])
                n = self.rng.standard_normal(4)
                c.rows.append((t, v_cx + s.cam_noise_m_s * n[0],
                               v_cy + s.cam_noise_m_s * n[1],
                               w + s.cam_yaw_rate_noise_rad_s * n[2],
                               snap.pose[2] + s.cam_yaw_noise_rad * n[3]))

    def _full_imu(self, snap: PlantSnapshot, a_xy: np.ndarray, wz: float) -> tuple:
        """``wx, wy, wz, ax, ay, az`` of one sample: ``a_xy``, ``wz`` (the vibration-free
        view's values) plus the batch model's vibration band and gravity."""
        s = self.settings
        w = self.rng_imu.standard_normal(8)
        col, self.vib_state = coloured_noise(w[None, :5], self.vib_pole, self.vib_state)
        if self.terrains:
            ter = self.terrains[int(snap.terrain_index)]
            vx, vy, r = (float(v) for v in snap.twist)
            level = vibration_level(np.array([math.hypot(vx, vy)]), np.array([r]),
                                    np.array([ter.vib_speed_m_s]))
            vib = vibration_signals(col, level, np.array([ter.vib_gyro_rad_s]),
                                    np.array([ter.vib_accel_m_s2]))[0]
        else:
            vib = np.zeros(5)
        g_x, g_y, g_z = (float(g) for g in gravity_specific_force(snap.pitch, snap.roll))
        return (vib[0] + s.gyro_noise_rad_s * w[5], vib[1] + s.gyro_noise_rad_s * w[6], wz,
                a_xy[0] + g_x + vib[2], a_xy[1] + g_y + vib[3],
                g_z + vib[4] + self.accel_bias_z + s.accel_noise_m_s2 * w[7])

    def take(self, t_s: float, omega_low_level: np.ndarray) -> Observation:
        """Samples since the previous call (and forget them).

        Parameters
        ----------
        t_s : float
            Time of the call, s.
        omega_low_level : ndarray, shape (m,)
            The robot's low-level wheel speed command, rad/s.

        Returns
        -------
        Observation
            Its arrays are its own (``omega_low_level`` a copy of the command given).
        """
        m = len(omega_low_level)
        widths = {"imu": 4, "wheels": 1 + m, "steer": 1 + m, "cam": 5, "currents": 1 + m}
        out = {}
        for name, c in self.ch.items():
            out[name] = (np.array(c.rows, dtype=float) if c.rows
                         else np.zeros((0, widths[name])))
            c.rows = []
        full = (np.array(self.imu_full_rows, dtype=float) if self.imu_full_rows
                else np.zeros((0, 7)))
        self.imu_full_rows = []
        # a copy: replay_observations passes a row of the finished run's omega_cmd, which a
        # controller adding its correction in place would have rewritten
        return Observation(t_s, np.array(omega_low_level, dtype=float), **out,
                           imu_full=full)


def make_hook(sensors: OnlineSensors, controller: Callable[[Observation], np.ndarray],
              control_rate_hz: float) -> ControlHook:
    """Integrator hook: sensors every step, the controller at ``control_rate_hz``.

    The ``n``-th call is due ``n`` periods after the first snapshot's time (the run's clock
    need not start at 0).

    Parameters
    ----------
    sensors : OnlineSensors
        The robot's sensors.
    controller : callable
        ``controller(observation) -> correction`` (rad/s, shape (m,)); sees only the
        :class:`Observation`.
    control_rate_hz : float
        Controller rate, Hz (> 0).

    Returns
    -------
    ControlHook

    Raises
    ------
    ConfigError
        A rate that is not a finite number > 0 (text, None or a boolean included), a
        controller that is not callable, or ``sensors`` without the ``record`` and ``take``
        of :class:`OnlineSensors`. The hook itself, at a step earlier than one it has seen:
        it serves one run (its call count and its sensors carry that run's state).
    """
    config_positive("make_hook", control_rate_hz=control_rate_hz)
    # each failed only at its first use, inside the run: None as the controller with a bare
    # TypeError at the first control call, None as the sensors with an AttributeError
    if not callable(controller):
        raise ConfigError(f"make_hook.controller must be callable, controller(observation) "
                          f"-> correction, got {type(controller).__name__}")
    if not all(callable(getattr(sensors, m, None)) for m in ("record", "take")):
        raise ConfigError(f"make_hook.sensors must be OnlineSensors (record and take), got "
                          f"{type(sensors).__name__}")
    period = 1.0 / control_rate_hz
    # t0: the run's first time, the n-th call is due n periods after it
    state = {"calls": 0, "t_s": -math.inf, "t0": None}

    def hook(snap: PlantSnapshot) -> np.ndarray | None:
        if snap.t_s < state["t_s"]:
            # a second run (its clock starts again): the call count and the sensors' state
            # are the first run's, and it called the controller not once, silently
            raise ConfigError(f"this closed-loop hook serves one run: it saw t = "
                              f"{state['t_s']:g} s, now t = {snap.t_s:g} s; make a new hook "
                              f"(and OnlineSensors) for each run")
        state["t_s"] = snap.t_s
        if state["t0"] is None:
            state["t0"] = snap.t_s
        sensors.record(snap)
        # the n-th call at n period after the first time (a running sum of periods drifts,
        # _Channel)
        if snap.t_s - state["t0"] + _schedule_tolerance(snap.t_s) < state["calls"] * period:
            return None
        state["calls"] += 1
        return controller(sensors.take(snap.t_s, snap.omega_low_level))

    return hook


def _check_sensor_rates(config: SimConfig, sensors: SensorSettings) -> None:
    """Refuse a sensor faster than the physics: :class:`OnlineSensors` samples once per
    physics step at most, so it would deliver the physics rate, not the sensor's.

    Raises
    ------
    ConfigError
        A rate of ``sensors`` the run's sensors use above ``config.physics_rate_hz``, named.
    """
    names = ["imu_rate_hz", "wheel_rate_hz"]
    if get_vehicle(config.vehicle).contact_geometry().steered:
        names += ["steer_rate_hz", "cam_rate_hz"]
    physics_hz = float(config.physics_rate_hz)
    fast = [f"{n} {getattr(sensors, n):g} Hz" for n in names
            if float(getattr(sensors, n)) > physics_hz * (1 + 1e-9)]
    if fast:
        raise ConfigError(f"the online sensors sample once per physics step, so a sensor "
                          f"faster than the physics ({physics_hz:g} Hz) would give the "
                          f"physics rate: {', '.join(fast)}; raise physics_rate_hz")


def _check_control_rate(config: SimConfig, control_rate_hz: float) -> None:
    """Refuse a controller rate the hook cannot deliver: it runs once per physics step at
    most, so a controller faster than the physics would be called at the physics rate.

    Raises
    ------
    ConfigError
        ``control_rate_hz`` not a finite number > 0 (text, None or a boolean included), or
        above ``config.physics_rate_hz``.
    """
    config_positive("closed loop", control_rate_hz=control_rate_hz)
    physics_hz = float(config.physics_rate_hz)
    if float(control_rate_hz) > physics_hz * (1 + 1e-9):
        raise ConfigError(f"the controller is called once per physics step at most, so "
                          f"control_rate_hz {control_rate_hz:g} Hz above the physics "
                          f"({physics_hz:g} Hz) would run at the physics rate; lower it or "
                          "raise physics_rate_hz")


def simulate_closed_loop(config: SimConfig, controller: Callable[[Observation], np.ndarray],
                         control_rate_hz: float = 50.0) -> Simulation:
    """Simulate with a controller in the loop.

    Parameters
    ----------
    config : SimConfig
        What to simulate (the sensors of ``config.sensors`` or the vehicle's defaults).
    controller : callable
        ``controller(observation) -> correction`` (rad/s per motor).
    control_rate_hz : float
        Controller rate, Hz (> 0, at most ``config.physics_rate_hz``).

    Returns
    -------
    Simulation
        As :func:`terrain.sim.simulate.simulate_with_physics`; ``physics.omega_cmd`` holds
        the corrected commands. With a camera, the run's metadata adds the outages of the
        controller's camera, ``controller_cam_outages_s`` (``[start, end)`` of each, s), and
        ``controller_cam_rows_dropped`` (camera samples they removed).

    Raises
    ------
    ConfigError
        Bad configuration or rate, a sensor or the controller faster than
        ``config.physics_rate_hz``, or a controller that is not callable.
    """
    _check_control_rate(config, control_rate_hz)
    settings = config.sensors or DEFAULT_SENSORS[config.vehicle]
    _check_sensor_rates(config, settings)
    sensors = OnlineSensors(config.vehicle, settings, config.seed, config.duration_s,
                            config.physics, config.terrains)
    sim = simulate_with_physics(config, make_hook(sensors, controller, control_rate_hz))
    if not sensors.steered:
        return sim
    meta = {**sim.run.meta,
            "controller_cam_outages_s": [[float(a), float(b)] for a, b in sensors.outages],
            "controller_cam_rows_dropped": int(sensors.cam_rows_dropped)}
    return replace(sim, run=replace(sim.run, meta=meta))


def replay_observations(sim: Simulation, control_rate_hz: float = 50.0):
    """Observations of a finished (open-loop) run, as a controller at ``control_rate_hz``
    would have received them, motor currents included.

    Replays the stored ground truth step by step through :class:`OnlineSensors` (same seed
    and sensors as :func:`simulate_closed_loop`); used to score estimators open loop, and to
    compare with the closed loop on the same seed.

    Parameters
    ----------
    sim : Simulation
        A run of :func:`terrain.sim.simulate.simulate_with_physics`.
    control_rate_hz : float
        Call rate, Hz (> 0, at most the run's ``physics_rate_hz``).

    Yields
    ------
    Observation
        Samples since the previous call.

    Raises
    ------
    ConfigError
        Non-positive rate, or a sensor or the call rate faster than the run's
        ``physics_rate_hz``.
    """
    cfg, phys = sim.config, sim.physics
    _check_control_rate(cfg, control_rate_hz)
    settings = cfg.sensors or DEFAULT_SENSORS[cfg.vehicle]
    _check_sensor_rates(cfg, settings)
    sensors = OnlineSensors(cfg.vehicle, settings, cfg.seed, cfg.duration_s, cfg.physics,
                            cfg.terrains)
    period, calls, n = 1.0 / control_rate_hz, 0, len(phys.t_s)
    t0 = float(phys.t_s[0])            # calls n periods after the run's first time
    for k in range(n):
        snap = PlantSnapshot(k, float(phys.t_s[k]), phys.pose[k], phys.twist[k],
                             phys.accel_body[k], phys.omega[k], phys.delta[k],
                             phys.omega_cmd[k], phys.torque[k],
                             float(phys.pitch[k]), float(phys.roll[k]),
                             int(phys.terrain_index[k]))
        sensors.record(snap)
        if snap.t_s - t0 + _schedule_tolerance(snap.t_s) >= calls * period:
            calls += 1
            yield sensors.take(snap.t_s, snap.omega_low_level)
