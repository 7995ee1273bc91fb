"""Run a simulation: vehicle, terrains, scenario, motors, sensors -> :class:`~terrain.run.Run`.

The simulated run follows the :mod:`terrain.run` contract (``t_s`` first, canonical channel
names, SI units); writing it in the measured-file layout is :func:`terrain.io.writer.write_run`.
Streams (file columns in brackets where the file names them differently):

``imu``    ``t_s, wx, wy, wz, ax, ay, az``       IMU at the body origin (rad/s, m/s^2)
``wheels`` ``t_s, cur_l, cur_r, vel_l, vel_r``   motor current magnitude (A), rim speed (m/s)
           (file ``pro``: ``time, curL, curR, velL, velR``).
           husky/tracked: left/right side. agrimaro: l = wheel 1 (d_1 = [-0.5075, 0]),
           r = wheel 2 (d_2 = [0.5075, 0]); all three wheels are in ``omega`` and ``cur``.
``truth``  ``t_s, x, y, yaw, v_bx, v_by, yaw_rate, slip_1.., omega_1.., pitch, roll, terrain``
           slip_i per motor (husky/tracked: 1 = left, 2 = right), SAE sign convention
           ``(omega r - v) / max(|omega r|, |v|, 0.02 m/s)`` (the floor,
           :data:`terrain.sim.forces.SLIP_SPEED_FLOOR_M_S`, keeps it linear near standstill:
           a 0.01 m/s speed difference at rest is slip 0.5, not 1); pitch nose-up positive;
           terrain label.
``steer``  ``t_s, delta_1, delta_2, delta_3`` steering encoders, rad (agrimaro): absolute
           encoders, each module's angle within one turn, [-pi, pi)
``cam``    ``t_s, v_cx, v_cy, yaw_rate_c, yaw_c`` T265 at its mount, velocities of the camera
           point in robot axes (x forward, y left; before the eq. 5.4 lever-arm correction),
           m/s, rad/s, rad; rows missing during outages (agrimaro; metadata
           ``cam_outages_s``: ``[start, end)`` of each, s; ``cam_rows_dropped``: rows removed;
           an outage that would leave fewer than :data:`MIN_STREAM_SAMPLES` rows is not planted)
``omega``  ``t_s, omega_1, omega_2, omega_3`` reported wheel speeds, rad/s (agrimaro)
``cur``    ``t_s, cur_1, cur_2, cur_3`` motor current magnitudes, A (agrimaro)

Metadata ``speed_limit_clipped_steps``: per motor, the physics steps on which the scenario's
command asked for more than the motor speed limit and was clipped to it (per side or wheel;
``terrain simulate`` says so in a note). Closed loop only, ``correction_clipped_steps``: per
motor, the physics steps on which the command plus the controller's correction exceeded the
limit and was clipped to it (``terrain control-sim`` reports both counts in its JSON).
Metadata ``implicit_iterations`` and ``implicit_unconverged_steps``: the Newton iterations
of the implicit-Euler steps after their first one, and the steps that stopped at
:data:`terrain.sim.dynamics.IMPLICIT_MAX_ITERATIONS` unconverged (none in the scenarios
measured on 2026-11-30).
Physics v2 with load transfer only, ``load_floor_steps``: per contact, the physics steps on
which its transferred normal load was floored at
:data:`terrain.sim.forces.MIN_LOAD_FRACTION` of its static load (a wheel about to lift; the
loads are then rescaled to the static total).
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass, field, is_dataclass
from types import MappingProxyType
from typing import Any, Mapping

import numpy as np
import pandas as pd

from terrain.errors import ConfigError, config_numbers, config_positive, config_seed
from terrain.run import TIME, Run
from terrain.sim.dynamics import ControlHook, PhysicsResult, integrate
from terrain.sim.effects import TURN_RATE_SCALE_RAD_S, Effects
from terrain.sim.forces import DEFAULT_PHYSICS, check_physics, reported_current_a
from terrain.sim.scenarios import (SCENARIO_NAMES, SCENARIO_SLOPES_RAD, make_commands,
                                   physics_steps)
from terrain.sim.sensors import (SensorSettings, encoder_count_rate, first_order_filter, imu,
                                 interp_columns, physics_step_index, quantise, sample_times,
                                 steering_encoder)
from terrain.terramechanics.catalogue import get_terrain
from terrain.vehicles import get_vehicle, point_velocity

#: Sensor settings of each vehicle (read-only). The Husky's follow BorealTC
#: (:class:`~terrain.sim.sensors.SensorSettings`); the AgriMaRo's 50 Hz wheel reports (its
#: encoder's count rate, speed quantum 0) and the tracked vehicle's 10 Hz reports with a
#: 1 mm/s quantum are ASSUMED: seeds 001 and 003 give no wheel report rate or resolution.
DEFAULT_SENSORS: Mapping[str, SensorSettings] = MappingProxyType({
    "husky": SensorSettings(),
    "agrimaro": SensorSettings(wheel_rate_hz=50.0, speed_quantum_m_s=0.0,
                               current_quantum_a=0.01),
    "tracked": SensorSettings(wheel_rate_hz=10.0, speed_quantum_m_s=0.001),
})


#: longest simulated run, s
MAX_DURATION_S = 7200.0
#: samples every stream of a simulated run holds at least: the readers of :mod:`terrain.io`
#: need two rows of a file to know its sample rate (:func:`terrain.io.measured.read_stream_csv`)
MIN_STREAM_SAMPLES = 2


def stream_rates_hz(vehicle: str, sensors: SensorSettings | None = None) -> dict[str, float]:
    """Sample rate of every stream file a simulated run of ``vehicle`` writes.

    Parameters
    ----------
    vehicle : str
        Vehicle name (:data:`terrain.vehicles.VEHICLE_NAMES`).
    sensors : SensorSettings or None
        None = the vehicle's defaults (:data:`DEFAULT_SENSORS`).

    Returns
    -------
    dict[str, float]
        File prefix (``imu``, ``pro``, ``truth``; ``steer``, ``cam``, ``omega``, ``cur`` for
        a steered vehicle) -> rate, Hz.

    Raises
    ------
    ConfigError
        Unknown vehicle, or ``sensors`` neither :class:`SensorSettings` nor None.
    """
    params = get_vehicle(vehicle)
    if sensors is not None and not isinstance(sensors, SensorSettings):
        # an empty dict was falsy and gave the defaults; other values an AttributeError
        raise ConfigError(f"sensors must be SensorSettings or None, got "
                          f"{type(sensors).__name__}")
    s = sensors or DEFAULT_SENSORS[params.name]
    rates = {"imu": s.imu_rate_hz, "pro": s.wheel_rate_hz, "truth": s.truth_rate_hz}
    if params.contact_geometry().steered:
        rates.update(steer=s.steer_rate_hz, cam=s.cam_rate_hz, omega=s.wheel_rate_hz,
                     cur=s.wheel_rate_hz)
    return {k: float(v) for k, v in rates.items()}


def minimum_duration_s(vehicle: str, sensors: SensorSettings | None = None,
                       physics_rate_hz: float = 100.0) -> tuple[float, str]:
    """Shortest duration whose run the project's readers accept.

    Every stream file must hold :data:`MIN_STREAM_SAMPLES` samples (streams are sampled at
    ``0, 1/rate, ...`` up to the duration), so the slowest stream sets the minimum: one of
    its sample periods, rounded up to whole physics steps (the duration is a whole number of
    steps). Husky 0.16 s (wheel reports at 6.5 Hz), tracked 0.1 s (wheels at 10 Hz),
    AgriMaRo 0.04 s (camera at 30 Hz), with the default sensors and 100 Hz physics. The
    AgriMaRo's simulated visual-odometry outages (0.5-2 s, :class:`SensorSettings`) remove
    camera rows of a short run too, but never so many that fewer than
    :data:`MIN_STREAM_SAMPLES` remain (such an outage is not planted).

    Parameters
    ----------
    vehicle : str
        Vehicle name.
    sensors : SensorSettings or None
        None = the vehicle's defaults (:data:`DEFAULT_SENSORS`).
    physics_rate_hz : float
        Integrator rate, Hz.

    Returns
    -------
    minimum_s : float
        Shortest duration, s.
    why : str
        The slowest stream, its rate and the number of physics steps.

    Raises
    ------
    ConfigError
        Unknown vehicle, ``sensors`` neither :class:`SensorSettings` nor None, or
        ``physics_rate_hz`` not a finite rate > 0 (0 was a ZeroDivisionError).
    """
    config_positive("minimum_duration_s", physics_rate_hz=physics_rate_hz)
    rates = stream_rates_hz(vehicle, sensors)
    slowest = min(rates, key=rates.get)
    period = (MIN_STREAM_SAMPLES - 1) / rates[slowest]
    rate = float(physics_rate_hz)
    # sample_times keeps a sample within 1e-9 s of the end: the fewest whole steps whose
    # span reaches the period to that tolerance
    steps = max(1, math.floor((period - 1e-9) * rate) + 1)
    minimum = steps / rate
    why = (f"{MIN_STREAM_SAMPLES} samples of every stream file, which the readers need to "
           f"know its rate; the slowest, {slowest} at {rates[slowest]:.4g} Hz, needs "
           f"{period:.4g} s = {steps} physics steps at {rate:g} Hz")
    return minimum, why


def parse_terrain_list(text: str) -> tuple[str, ...]:
    """Terrain names of a comma-separated list (``"SNOW"``, ``"ICE, SNOW"``), upper case.

    Parameters
    ----------
    text : str
        One terrain class, or classes separated by commas (spaces around them allowed).

    Returns
    -------
    tuple of str
        The names, stripped and upper case, in order (their validity is checked by
        :class:`SimConfig`).

    Raises
    ------
    ConfigError
        An empty name (``"SNOW,"``, ``",SNOW"``, ``"ICE,,SNOW"``, ``""``).
    """
    names = tuple(t.strip().upper() for t in str(text).split(","))
    empty = [i + 1 for i, t in enumerate(names) if not t]
    if empty:
        raise ConfigError(f"empty terrain name at position {', '.join(map(str, empty))} of "
                          f"the terrain list {text!r}; give names separated by single commas")
    return names


def is_name_sequence(value: Any) -> bool:
    """Whether ``value`` can be a sequence of names (terrains of a run).

    Parameters
    ----------
    value : object
        What was given.

    Returns
    -------
    bool
        True for a list, tuple or other iterable; False for one string or bytes (iterated
        letter by letter, byte by byte) and for what is not iterable (a number).
    """
    if isinstance(value, (str, bytes, bytearray)):
        return False
    try:
        iter(value)
    except TypeError:
        return False
    return True


@dataclass(frozen=True)
class SimConfig:
    """What to simulate.

    Parameters
    ----------
    vehicle : str
        ``agrimaro``, ``husky`` or ``tracked`` (any case; kept as the catalogue's name).
    terrains : tuple of str
        Terrain classes along the path (changing every ``segment_length_m``, cycling); a
        sequence of names, not one string (:func:`parse_terrain_list` splits ``"A,B"``).
        Any case; kept as the catalogue's names (``"snow"`` -> ``"SNOW"``).
    scenario : str
        One of :data:`~terrain.sim.scenarios.SCENARIO_NAMES`.
    duration_s : float
        Simulated time, s, at most 7200 and at least :func:`minimum_duration_s` (every stream
        file must hold :data:`MIN_STREAM_SAMPLES` samples: 0.16 s for the Husky, 0.1 s for the
        tracked vehicle, 0.04 s for the AgriMaRo at the default rates). Rounded to the
        physics step.
    seed : int
        Seed of the run's :class:`numpy.random.Generator`.
    effects : Effects
        Planted effects (all off by default).
    segment_length_m : float
        Distance between terrain changes, m (finite, > 0).
    physics_rate_hz : float
        Integrator rate, Hz (50-1000).
    sensors : SensorSettings or None
        None = the vehicle's defaults (:data:`DEFAULT_SENSORS`).
    physics : str
        Physics version, :data:`terrain.sim.forces.PHYSICS_VERSIONS`: ``v1`` static loads and
        Coulomb lateral friction; ``v2`` load transfer and the lateral wheel-soil model
        (docs/physics_v2.md).

    Raises
    ------
    ConfigError
        Unknown vehicle, terrain, scenario or physics version (the message lists the valid
        choices), or a duration, rate, segment length or seed out of range (a duration too short for
        two samples of every stream names the slowest stream and the minimum in seconds),
        or terrains that are not a sequence of names (one string, bytes, a number),
        or ``icr_expansion`` planted on a steered vehicle or ``grade_resistance`` on a level
        scenario (:data:`~terrain.sim.scenarios.SCENARIO_SLOPES_RAD`; either would change
        nothing), or a number given as text, None or a boolean, or ``effects`` not
        :class:`Effects`.
    """

    vehicle: str = "husky"
    terrains: tuple[str, ...] = ("ASPHALT",)
    scenario: str = "random"
    duration_s: float = 60.0
    seed: int = 0
    effects: Effects = field(default_factory=Effects)
    segment_length_m: float = 25.0
    physics_rate_hz: float = 100.0
    sensors: SensorSettings | None = None
    physics: str = DEFAULT_PHYSICS

    def __post_init__(self) -> None:
        # before the range checks: text, None or a boolean is named, not a TypeError there
        config_numbers("SimConfig", duration_s=self.duration_s,
                       segment_length_m=self.segment_length_m,
                       physics_rate_hz=self.physics_rate_hz)
        if not isinstance(self.effects, Effects):
            raise ConfigError(f"SimConfig.effects must be Effects (parse_effects builds one "
                              f"from NAME=VALUE items), got {type(self.effects).__name__}")
        vehicle = get_vehicle(self.vehicle)
        # the catalogue's name (get_vehicle takes any case): DEFAULT_SENSORS and the closed
        # loop look the vehicle up by it
        object.__setattr__(self, "vehicle", vehicle.name)
        check_physics(self.physics)
        if isinstance(self.terrains, str):
            raise ConfigError(f"terrains must be a sequence of terrain names, got the string "
                              f"{self.terrains!r} (split a comma-separated list with "
                              "parse_terrain_list)")
        if not is_name_sequence(self.terrains):
            # 5 was a bare TypeError (not iterable), b"ASPHALT" "unknown terrain 65"
            raise ConfigError(f"SimConfig.terrains must be a sequence of terrain names, got "
                              f"{type(self.terrains).__name__} {self.terrains!r:.60}")
        # once: a generator, iterated by the checks below, left the run no terrain
        object.__setattr__(self, "terrains", tuple(self.terrains))
        if not self.terrains:
            raise ConfigError("at least one terrain is needed")
        for t in self.terrains:
            if not str(t).strip():
                raise ConfigError(f"empty terrain name in terrains {tuple(self.terrains)!r}")
        # the catalogue's names (get_terrain takes any case): the run's label, its folder and
        # the truth stream's per-sample labels must be the same class name
        object.__setattr__(self, "terrains", tuple(get_terrain(t).name for t in self.terrains))
        if self.scenario not in SCENARIO_NAMES:
            raise ConfigError(f"unknown scenario {self.scenario!r}; valid choices: "
                              f"{', '.join(SCENARIO_NAMES)}")
        if not (50.0 <= float(self.physics_rate_hz) <= 1000.0):
            raise ConfigError(f"physics_rate_hz must be in [50, 1000], got {self.physics_rate_hz}")
        if self.sensors is not None and not isinstance(self.sensors, SensorSettings):
            raise ConfigError(f"sensors must be SensorSettings or None, got "
                              f"{type(self.sensors).__name__}")
        if not (0.0 < float(self.duration_s) <= MAX_DURATION_S):
            raise ConfigError(f"duration_s must be in (0, {MAX_DURATION_S:g}] s, got "
                              f"{self.duration_s}")
        minimum, why = minimum_duration_s(vehicle.name, self.sensors, self.physics_rate_hz)
        dt = 1.0 / float(self.physics_rate_hz)
        if physics_steps(self.duration_s, dt) < physics_steps(minimum, dt):
            raise ConfigError(f"a duration of {self.duration_s} s is too short for the "
                              f"{vehicle.name}: the minimum is {minimum:g} s ({why})")
        if not 0 < float(self.segment_length_m) < math.inf:
            # inf kept a multi-terrain run on its first terrain and wrote Infinity to its meta
            raise ConfigError(f"segment_length_m must be a finite length > 0, m, got "
                              f"{self.segment_length_m}")
        config_seed("seed", self.seed)
        if self.effects.icr_expansion != 1.0 and vehicle.contact_geometry().steered:
            # simulate() applies chi to skid-steered vehicles only: planted on a steered one
            # it would be listed as active in the run's metadata and change nothing
            raise ConfigError(f"icr_expansion is a skid-steer effect (yaw rate (v_R - v_L) / "
                              f"(chi B)); the {vehicle.name} is steered, so it would change "
                              "nothing: leave it out")
        if self.effects.grade_resistance != 0.0 and SCENARIO_SLOPES_RAD[self.scenario] == 0.0:
            # motor_currents adds grade_resistance |pitch|: on level ground pitch is 0, so the
            # run's metadata would list the effect as active and no stream would change
            raise ConfigError(f"grade_resistance adds current in proportion to |pitch|; the "
                              f"{self.scenario} scenario is on level ground, so it would "
                              "change nothing: plant it on slope_turn or leave it out")

    @property
    def run_terrain(self) -> str:
        """The run's terrain label: the terrain, or ``MIXED`` for a list of several distinct
        ones (the ``terrain`` of its metadata and the folder
        :func:`terrain.io.writer.write_run` puts it in; ``ICE, ICE`` is an ICE run)."""
        return self.terrains[0] if len(set(self.terrains)) == 1 else "MIXED"


@dataclass(frozen=True)
class Simulation:
    """A simulated run with its ground truth at the physics rate.

    Parameters
    ----------
    config : SimConfig
        What was simulated.
    run : Run
        The run (:mod:`terrain.run` contract: sensor streams, the ``truth`` stream at the
        truth rate and JSON-serialisable metadata, written as ``meta_XX.json``).
    physics : PhysicsResult
        Ground truth at every physics step (body accelerations, steering angles and motor
        torques included, which the ``truth`` stream does not carry).
    """

    config: SimConfig
    run: Run
    physics: PhysicsResult


def _jsonable(obj: Any) -> Any:
    if is_dataclass(obj):
        d = {"type": type(obj).__name__}
        d.update({k: _jsonable(v) for k, v in asdict(obj).items()})
        return d
    if isinstance(obj, dict):
        return {str(k): _jsonable(v) for k, v in obj.items()}
    if isinstance(obj, (list, tuple)):
        return [_jsonable(v) for v in obj]
    if isinstance(obj, np.ndarray):
        return obj.tolist()
    if isinstance(obj, (np.floating, np.integer)):
        return obj.item()
    return obj


def motor_currents(phys: PhysicsResult, vehicle, effects: Effects, physics: str = "v1"
                   ) -> np.ndarray:
    """Motor current magnitudes with the planted current effects.

    The motor law of the vehicle (:meth:`terrain.vehicles.MotorParams.current_from_torque`)
    applied to the true torques and speeds, plus ``turning_resistance``,
    ``grade_resistance`` and ``current_offset`` (:mod:`terrain.sim.effects`).

    Parameters
    ----------
    phys : PhysicsResult
        Ground truth at the physics rate (n steps, m motors).
    vehicle : AgriMaRoParams or HuskyParams or TrackedParams
        Vehicle (its ``motor``).
    effects : Effects
        Planted effects.
    physics : str
        Physics version (``v2`` reports the no-load current while a motor brakes,
        :func:`terrain.sim.forces.reported_current_a`).

    Returns
    -------
    ndarray, shape (n, m)
        Current magnitudes, A.
    """
    cur = reported_current_a(vehicle.motor, phys.torque, phys.omega, physics)
    turning = effects.turning_resistance * np.tanh(np.abs(phys.twist[:, 2])
                                                   / TURN_RATE_SCALE_RAD_S)
    cur = cur + turning[:, None] + effects.grade_resistance * np.abs(phys.pitch)[:, None]
    if effects.current_offset > 0:
        cur[:, 1] += effects.current_offset
    elif effects.current_offset < 0:
        cur[:, 0] += -effects.current_offset
    return cur


def steering_offsets(vehicle, geometry, seed: int) -> np.ndarray | None:
    """The robot's constant steering errors inside the dead band (seed 001 ch. 6.1.1).

    A property of the robot, not of the drive: drawn uniformly in ``[-d, d]`` (``d`` the
    vehicle's ``steering_dead_band_rad``) from a generator of their own, the first child
    of the run seed's :class:`numpy.random.SeedSequence` (the run's generator, which draws
    the scenario and the sensor noise, is the seed's own stream), so every run of one seed,
    whatever its scenario or duration, drives the same robot. Until 2026-11-30 they were
    drawn from the run's generator after the random scenario's segments, whose number
    depends on the duration.

    Parameters
    ----------
    vehicle : AgriMaRoParams or HuskyParams or TrackedParams
        Vehicle (its ``steering_dead_band_rad``).
    geometry : ContactGeometry
        Its contact geometry.
    seed : int
        Run seed.

    Returns
    -------
    ndarray, shape (n_motors,), or None
        Offsets, rad; None for a vehicle that does not steer.
    """
    if not geometry.steered:
        return None
    rng = np.random.default_rng(np.random.SeedSequence(int(seed)).spawn(1)[0])
    db = vehicle.steering_dead_band_rad
    return rng.uniform(-db, db, geometry.n_motors)


def simulate(config: SimConfig) -> Run:
    """Simulate one run.

    Parameters
    ----------
    config : SimConfig
        Vehicle, terrains, scenario, duration, seed, planted effects, sensors.

    Returns
    -------
    Run
        ``dataset = "sim"``, run id ``sim/<TERRAIN>/<scenario>/<seed>``, streams as in the
        module docstring, metadata (settings, rates, parameters of vehicle, terrains and
        sensors).

    Raises
    ------
    ConfigError
        Bad configuration (names list the valid choices).
    """
    return simulate_with_physics(config).run


def simulate_with_physics(config: SimConfig, hook: ControlHook | None = None) -> Simulation:
    """Simulate one run and keep the ground truth at the physics rate.

    Parameters
    ----------
    config : SimConfig
        Vehicle, terrains, scenario, duration, seed, planted effects, sensors.
    hook : ControlHook, optional
        Closed-loop hook of :func:`terrain.sim.dynamics.integrate` (see
        :func:`terrain.sim.closed_loop.simulate_closed_loop`); None: open loop. The hook draws
        no number from the run's generator, so the sensor streams' noise is the same as in
        the open-loop run of the same seed.

    Returns
    -------
    Simulation
        The run of :func:`simulate` and the :class:`PhysicsResult` it was sampled from.

    Raises
    ------
    ConfigError
        Bad configuration (names list the valid choices).
    """
    vehicle = get_vehicle(config.vehicle)
    geometry = vehicle.contact_geometry()
    terrains = tuple(get_terrain(t) for t in config.terrains)
    sensors = config.sensors or DEFAULT_SENSORS[vehicle.name]
    rng = np.random.default_rng(int(config.seed))
    dt = 1.0 / float(config.physics_rate_hz)
    vmax = vehicle.motor.max_wheel_speed_rad_s * vehicle.wheel_radius_m
    cmds = make_commands(config.scenario, float(config.duration_s), dt, rng, vmax,
                         omnidirectional=geometry.steered,
                         track_m=0.0 if geometry.steered else vehicle.track_m)
    steer_offset = steering_offsets(vehicle, geometry, int(config.seed))
    chi = 1.0 if geometry.steered else config.effects.icr_expansion
    phys = integrate(vehicle, geometry, terrains, config.segment_length_m, cmds.t_s,
                     cmds.twist, cmds.slope_rad, chi, steer_offset, hook=hook,
                     physics=config.physics)
    duration = float(cmds.t_s[-1])
    r_w = geometry.wheel_radius_m
    streams: dict[str, pd.DataFrame] = {}

    t_imu, imu_data = imu(phys, terrains, sensors, config.effects.gyro_bias, rng, duration)
    streams["imu"] = pd.DataFrame(np.column_stack([t_imu, imu_data]),
                                  columns=[TIME, "wx", "wy", "wz", "ax", "ay", "az"])

    # wheel encoders and motor currents: driver filter, then the wheel_lag effect
    motor = vehicle.motor
    omega_meas = phys.omega
    if sensors.speed_quantum_m_s == 0:
        omega_meas = encoder_count_rate(phys.omega, dt, motor.encoder_counts_per_rev)
    omega_rep = first_order_filter(omega_meas, dt, motor.encoder_filter_s)
    cur = motor_currents(phys, vehicle, config.effects, config.physics)
    t_w = sample_times(duration, sensors.wheel_rate_hz)
    t_src = np.clip(t_w - config.effects.wheel_lag, 0.0, None)
    om_w = interp_columns(t_src, phys.t_s, omega_rep)
    vel_w = quantise(om_w * r_w, sensors.speed_quantum_m_s)
    if sensors.speed_quantum_m_s > 0:
        om_w = vel_w / r_w      # the omega stream reports the same quantised encoder speed
    cur_w = interp_columns(t_src, phys.t_s, cur)
    cur_w = quantise(np.abs(cur_w + sensors.current_noise_a * rng.standard_normal(cur_w.shape)),
                     sensors.current_quantum_a)
    streams["wheels"] = pd.DataFrame({TIME: t_w, "cur_l": cur_w[:, 0], "cur_r": cur_w[:, 1],
                                      "vel_l": vel_w[:, 0], "vel_r": vel_w[:, 1]})
    if geometry.n_motors > 2:
        streams["omega"] = pd.DataFrame(
            {TIME: t_w, **{f"omega_{i + 1}": om_w[:, i] for i in range(geometry.n_motors)}})
        streams["cur"] = pd.DataFrame(
            {TIME: t_w, **{f"cur_{i + 1}": cur_w[:, i] for i in range(geometry.n_motors)}})

    # ground truth
    t_tr = sample_times(duration, sensors.truth_rate_hz)
    idx = physics_step_index(phys.t_s, t_tr)
    truth = {TIME: t_tr, "x": phys.pose[idx, 0], "y": phys.pose[idx, 1],
             "yaw": phys.pose[idx, 2], "v_bx": phys.twist[idx, 0], "v_by": phys.twist[idx, 1],
             "yaw_rate": phys.twist[idx, 2]}
    for i in range(geometry.n_motors):
        truth[f"slip_{i + 1}"] = phys.slip_motor[idx, i]
    for i in range(geometry.n_motors):
        truth[f"omega_{i + 1}"] = phys.omega[idx, i]
    truth["pitch"] = phys.pitch[idx]
    truth["roll"] = phys.roll[idx]
    truth["terrain"] = np.asarray(phys.terrain_names)[phys.terrain_index[idx]]
    streams["truth"] = pd.DataFrame(truth)

    if geometry.steered:
        t_st = sample_times(duration, sensors.steer_rate_hz)
        d = steering_encoder(interp_columns(t_st, phys.t_s, phys.delta),
                             sensors.steer_quantum_rad)
        streams["steer"] = pd.DataFrame(
            {TIME: t_st, **{f"delta_{i + 1}": d[:, i] for i in range(geometry.n_motors)}})
        t_c = sample_times(duration, sensors.cam_rate_hz)
        s = interp_columns(t_c, phys.t_s, np.column_stack([phys.twist, phys.pose[:, 2]]))
        lever = vehicle.camera_lever_arm_m
        # v + omega x d (eq. 5.4 inverted), the relation the EKF's h(x) uses
        v_cx, v_cy = point_velocity(s[:, 0], s[:, 1], s[:, 2], lever[0], lever[1])
        nz = rng.standard_normal((len(t_c), 4))
        cam = pd.DataFrame({TIME: t_c, "v_cx": v_cx + sensors.cam_noise_m_s * nz[:, 0],
                            "v_cy": v_cy + sensors.cam_noise_m_s * nz[:, 1],
                            "yaw_rate_c": s[:, 2] + sensors.cam_yaw_rate_noise_rad_s * nz[:, 2],
                            "yaw_c": s[:, 3] + sensors.cam_yaw_noise_rad * nz[:, 3]})
        keep = np.ones(len(t_c), dtype=bool)
        n_out = rng.poisson(sensors.cam_outage_rate_hz * duration)
        cam_outages = []
        for start, length in zip(rng.uniform(0, duration, n_out), rng.uniform(0.5, 2.0, n_out)):
            left = keep & ~((t_c >= start) & (t_c < start + length))
            if left.sum() < MIN_STREAM_SAMPLES:
                # an outage over (nearly) the whole of a short run left the camera file
                # unreadable (one row: its rate unknown); it is not planted, nor listed
                continue
            keep = left
            cam_outages.append([float(start), float(start + length)])
        streams["cam"] = cam[keep].reset_index(drop=True)

    rates = {"physics": float(config.physics_rate_hz), **stream_rates_hz(vehicle.name, sensors)}
    meta = {
        "vehicle": vehicle.name, "dataset": "sim", "scenario": config.scenario,
        "seed": int(config.seed), "duration_s": duration, "physics": config.physics,
        "terrain": config.run_terrain,
        "terrains": list(config.terrains), "segment_length_m": float(config.segment_length_m),
        "effects": config.effects.as_dict(), "active_effects": config.effects.active(),
        "rates_hz": rates, "slope_rad": cmds.slope_rad,
        "steering_offset_rad": None if steer_offset is None else steer_offset.tolist(),
        "pro_mapping": ("velL/curL = wheel 1, velR/curR = wheel 2" if geometry.steered
                        else "velL/curL = left side, velR/curR = right side"),
        "vehicle_params": _jsonable(vehicle),
        "terrain_params": {t.name: _jsonable(t) for t in terrains},
        "sensor_settings": _jsonable(sensors),
        # physics steps on which each motor's command exceeded its speed limit (clipped there)
        "speed_limit_clipped_steps": phys.speed_clipped_steps.tolist(),
        # closed loop: steps on which the corrected command exceeded it (clipped there)
        **({"correction_clipped_steps": phys.correction_clipped_steps.tolist()}
           if phys.correction_clipped_steps is not None else {}),
        # implicit-Euler steps: Newton iterations after the first, linearly implicit, one and
        # the steps that stopped at the iteration limit unconverged (their best iterate kept)
        "implicit_iterations": phys.implicit_iterations,
        "implicit_unconverged_steps": phys.implicit_unconverged_steps,
        # physics v2 load transfer: steps on which each contact's load sat at its floor
        **({"load_floor_steps": phys.load_floor_steps.tolist()}
           if phys.load_floor_steps is not None else {}),
        # the simulated visual-odometry outages and the camera rows they removed
        **({"cam_outages_s": cam_outages, "cam_rows_dropped": int(np.sum(~keep))}
           if geometry.steered else {}),
        "units": {"time": "s", "wx": "rad/s", "ax": "m/s^2", "cur": "A", "vel": "m/s",
                  "delta": "rad", "omega": "rad/s", "v_c": "m/s", "yaw": "rad"},
    }
    # one id per terrain, scenario and seed (it was sim/<TERRAIN>/<seed>, one id for every
    # scenario, while windows are grouped and counted by run id)
    run = Run(run_id=f"sim/{meta['terrain']}/{config.scenario}/{int(config.seed)}",
              dataset="sim",
              terrain=str(meta["terrain"]), streams=streams, vehicle=vehicle.name,
              source="terrain.sim", meta=meta)
    return Simulation(config=config, run=run, physics=phys)
