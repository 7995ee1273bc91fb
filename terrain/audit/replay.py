"""Replay: drive the simulator's skid-steer model with a measured run's own wheel speeds.

What "baseline" means in the audit
----------------------------------
The baseline is the simulator's Husky model *as is*, every named effect off
(:mod:`terrain.sim.effects`): the planar rigid-body dynamics of
:func:`terrain.sim.dynamics.integrate` on the run's terrain from
:mod:`terrain.terramechanics.catalogue`, flat ground, the motor current law of
:class:`terrain.vehicles.common.MotorParams`. The measured left/right wheel speeds are imposed
on the motors:

* the speed loop's time constant is set to the physics step, so the simulated wheel speed at
  each step *is* the measured one, linearly interpolated from the wheel stream (the stream
  reports the wheels' actual speed, so no further actuator lag is applied);
* the speed limit is raised (``speed_headroom``) so that measured speeds are never clipped.

With these inputs the physics predicts the body twist (hence the yaw rate, including the
lateral scrub that the contact model produces by itself), the body-frame accelerations (what
a level, unbiased accelerometer would read minus gravity) and the motor currents (traction,
rolling loss and wheel inertia torque through
``I = I_0 tanh(omega / 0.05 rad/s) + T / (G k_t eta)``, reported as magnitudes like the
simulator's sensor model).

Predictions are low-pass filtered (zero phase, ``output_cutoff_hz``) and sampled at the
wheel-stream timestamps, the clock on which the audit compares them with measurements.

References
----------
Seed ``000_f24201ff985633bf.txt`` eqs. 1-3 (skid-steer kinematics with slip); the contact
model and its sources are documented in :mod:`terrain.sim.dynamics`.
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np
from scipy import signal

from terrain.errors import (ConfigError, DataFormatError, TimestampError, config_flags,
                            config_positive)
from terrain.run import TIME, Run, times_out_of_order
from terrain.sim.dynamics import integrate
from terrain.sim.forces import DEFAULT_PHYSICS, check_physics, reported_current_a
from terrain.sim.simulate import SimConfig
from terrain.terramechanics.catalogue import TerrainParams, get_terrain
from terrain.vehicles import get_vehicle, skid_steer_forward

#: vehicles the replay supports (skid-steer: two drive sides, left = motor 0)
SKID_STEER_VEHICLES = ("husky", "tracked")


@dataclass(frozen=True)
class ReplaySettings:
    """How measured runs are replayed through the simulator.

    Parameters
    ----------
    physics_rate_hz : float
        Integrator rate, Hz (50-1000). Default: the simulator's own default
        (:class:`terrain.sim.SimConfig`), because the simulated currents depend on the step
        (about +-0.4 A on asphalt between 50 and 200 Hz): the baseline is the simulator as
        it runs by default.
    output_cutoff_hz : float
        Cut-off of the zero-phase 4th-order Butterworth low-pass applied to the predictions
        before they are sampled at the wheel timestamps, Hz. The same filter is applied to
        the IMU (:mod:`terrain.audit.frames`) so that both sides of every comparison have the
        same bandwidth; 2 Hz is below the Nyquist rate of the ~6.5 Hz BorealTC wheel stream.
    speed_headroom : float
        The replay vehicle's wheel-speed limit is at least ``speed_headroom`` times the
        largest measured wheel speed (no clipping of measured inputs).
    physics : str
        Physics version of the replayed simulator (:data:`terrain.sim.forces.PHYSICS_VERSIONS`);
        default the simulator's default, so ``replay_rmse`` always means the default physics.
    merge_subresolution : bool
        When the wheel stream is quantised (:func:`speed_resolution`), a left-right speed
        difference of at most one resolution step carries no information (the true one lies
        anywhere within a step) and both sides are replayed at their mean. Without this, at a
        speed where the two sides round to neighbouring steps (0.5 m/s is 63.5 steps of
        0.2/25.4 m/s), the replayed robot fights a fictitious 8 mm/s speed difference and its
        currents split by about +-0.9 A on asphalt.
    input_cutoff_hz : float or None
        Cut-off of a zero-phase 4th-order Butterworth low-pass applied to the measured wheel
        speeds before they drive the replay, Hz (:func:`lowpass`, at the wheel stream's
        median rate); ``None`` (default): the record as measured. The smoothed speeds are
        then the replay's inputs everywhere (``Replay.vel_l``/``vel_r``, hence the commanded
        yaw rate and the manoeuvres of the audit frame). A noisy speed record makes the
        replayed motors brake and accelerate with the noise, and the reported current is a
        magnitude, so the noise is rectified and survives ``output_cutoff_hz``: on the Vulpi
        runs (15 Hz, rms wheel acceleration about 3 m/s^2 while cruising, against 0.04-0.57
        on BorealTC) 2 Hz cuts the replay's current RMSE from 4.42 to 1.35 A (v1) and 2.63 to
        1.28 A (v2), and changes BorealTC's by 0.02 A or less
        (``benchmarks/replay_input_lowpass.py``, docs/physics_v2.md).
    """

    physics_rate_hz: float = SimConfig.physics_rate_hz
    output_cutoff_hz: float = 2.0
    speed_headroom: float = 1.5
    merge_subresolution: bool = True
    physics: str = DEFAULT_PHYSICS
    input_cutoff_hz: float | None = None

    def __post_init__(self) -> None:
        """Refuse settings out of range (ConfigError naming them): an infinite
        ``input_cutoff_hz`` read as "no low-pass" but was clipped to 0.45 of the wheel rate
        and filtered the inputs, ``True`` passed as a 1 Hz cut-off or a headroom of 1, the
        text ``"100"`` as a physics rate, and ``merge_subresolution="no"`` merged the sides."""
        check_physics(self.physics)
        config_positive("ReplaySettings", output_cutoff_hz=self.output_cutoff_hz,
                        speed_headroom=self.speed_headroom, physics_rate_hz=self.physics_rate_hz)
        config_flags("ReplaySettings", merge_subresolution=self.merge_subresolution)
        if self.input_cutoff_hz is not None:
            config_positive("ReplaySettings", input_cutoff_hz=self.input_cutoff_hz)
        if not 50.0 <= float(self.physics_rate_hz) <= 1000.0:
            raise ConfigError(f"physics_rate_hz must be in [50, 1000], got {self.physics_rate_hz}")
        if not 0.0 < float(self.output_cutoff_hz) < 0.5 * float(self.physics_rate_hz):
            raise ConfigError(f"output_cutoff_hz must be in (0, physics_rate_hz / 2), got "
                              f"{self.output_cutoff_hz}")
        if not float(self.speed_headroom) >= 1.0:
            raise ConfigError(f"speed_headroom must be >= 1, got {self.speed_headroom}")
        if self.input_cutoff_hz is not None and not float(self.input_cutoff_hz) > 0.0:
            raise ConfigError(f"input_cutoff_hz must be > 0 or None, got {self.input_cutoff_hz}")


@dataclass(frozen=True)
class Replay:
    """Simulator predictions for one measured run, on the run's wheel clock.

    Attributes
    ----------
    run_id : str
    terrain : str
        Catalogue terrain used.
    vehicle : str
    track_m : float
        Track width B of the replayed vehicle, m.
    t_s : ndarray, shape (n,)
        Wheel-stream timestamps, s.
    vel_l, vel_r : ndarray, shape (n,)
        Measured wheel (rim) speeds, m/s (the replay's inputs, before the sub-resolution
        merge of :class:`ReplaySettings`; after its ``input_cutoff_hz`` low-pass when set,
        and a smoothed record is no longer quantised, so no merge applies then).
    yaw_rate : ndarray, shape (n,)
        Predicted yaw rate, rad/s.
    ax, ay : ndarray, shape (n,)
        Predicted body-frame kinematic acceleration (level ground, no gravity), m/s^2.
    v_x : ndarray, shape (n,)
        Predicted forward body speed, m/s.
    cur : ndarray, shape (n, 2)
        Predicted motor current magnitudes, left and right, A.
    """

    run_id: str
    terrain: str
    vehicle: str
    track_m: float
    t_s: np.ndarray
    vel_l: np.ndarray
    vel_r: np.ndarray
    yaw_rate: np.ndarray
    ax: np.ndarray
    ay: np.ndarray
    v_x: np.ndarray
    cur: np.ndarray


#: Highest low-pass cut-off of :func:`lowpass` as a fraction of the sampling rate (below the
#: Nyquist frequency, 0.5, where a Butterworth design fails).
MAX_CUTOFF_FRACTION = 0.45

#: Order of :func:`lowpass`'s Butterworth filter.
LOWPASS_ORDER = 4
#: Fewest samples :func:`lowpass` filters: ``scipy.signal.sosfiltfilt`` extends each end by
#: ``3 (2 n_sections + 1)`` samples (15 for the two second-order sections of the 4th order)
#: and needs a longer series; a shorter one is returned unfiltered.
LOWPASS_MIN_SAMPLES = 3 * (2 * (LOWPASS_ORDER // 2) + 1) + 1


def lowpass_cutoff_hz(rate_hz: float, cutoff_hz: float) -> float:
    """The cut-off :func:`lowpass` uses: the one asked, clipped to
    :data:`MAX_CUTOFF_FRACTION` of the sampling rate.

    Parameters
    ----------
    rate_hz : float
        Sampling rate, Hz.
    cutoff_hz : float
        Cut-off asked for, Hz.

    Returns
    -------
    float
        Cut-off used, Hz.
    """
    return min(float(cutoff_hz), MAX_CUTOFF_FRACTION * float(rate_hz))


def lowpass(values: np.ndarray, rate_hz: float, cutoff_hz: float, padtype: str = "odd"
            ) -> np.ndarray:
    """Zero-phase 4th-order Butterworth low-pass along axis 0.

    Parameters
    ----------
    values : ndarray, shape (n,) or (n, k)
    rate_hz : float
        Sampling rate of ``values``, Hz.
    cutoff_hz : float
        Cut-off, Hz; clipped to :data:`MAX_CUTOFF_FRACTION` of ``rate_hz``.
    padtype : {"odd", "even"}
        Extension of the series at its ends (``scipy.signal.sosfiltfilt``): ``odd`` keeps
        the end values (and a trend) exactly, ``even`` mirrors the series, so a noisy end
        sample weighs no more than any other (for a slow trend of a noisy signal).

    Returns
    -------
    ndarray, same shape
        Filtered values (unchanged when the series holds fewer than
        :data:`LOWPASS_MIN_SAMPLES`, too short to filter).

    Raises
    ------
    ConfigError
        ``rate_hz`` or ``cutoff_hz`` not a finite number > 0 (a boolean included; scipy
        answered "Digital filter critical frequencies must be 0 < Wn < fs/2"), or a
        cut-off so far below the rate that the filter cannot be computed (scipy's
        "Singular matrix", about 1e-9 of the rate).
    """
    config_positive("lowpass", rate_hz=rate_hz, cutoff_hz=cutoff_hz)
    values = np.asarray(values, dtype=float)
    fc = lowpass_cutoff_hz(rate_hz, cutoff_hz)
    sos = signal.butter(LOWPASS_ORDER, fc, fs=float(rate_hz), output="sos")
    if values.shape[0] < LOWPASS_MIN_SAMPLES:
        return values
    try:
        return signal.sosfiltfilt(sos, values, axis=0, padtype=padtype)
    except np.linalg.LinAlgError:   # scipy's filter start: "Singular matrix" (1e-12 Hz)
        raise ConfigError(f"lowpass: cut-off {fc:g} Hz is too low for a {float(rate_hz):g} Hz "
                          "series: its filter cannot be computed (give a higher cut-off)"
                          ) from None


#: rms wheel acceleration while cruising above which a wheel-speed record is called jittery,
#: m/s^2: ASSUMED between the shipped records, BorealTC 0.04-0.57 (6.5 Hz, quantised) and
#: Vulpi 2.91-3.00 (15 Hz; about every 4th sample reads half the speed), see
#: docs/physics_v2.md, "Vulpi runs"
JITTER_ACCEL_M_S2 = 1.5


def cruise_wheel_acceleration_rms(run: Run, min_speed_m_s: float = 0.3) -> float:
    """RMS of the wheel-speed record's sample-to-sample acceleration while cruising, m/s^2.

    A robot cruising under a constant command accelerates little; a record whose differences
    are large there holds a counting or time-stamping artefact, which a replay imposing the
    record on the motors turns into braking and driving current (see
    :attr:`ReplaySettings.input_cutoff_hz`).

    Parameters
    ----------
    run : Run
        Needs a ``wheels`` stream (``t_s, vel_l, vel_r``).
    min_speed_m_s : float
        Samples whose mean wheel speed magnitude is at least this are cruising, m/s.

    Returns
    -------
    float
        RMS of ``diff(v) / diff(t)`` of the mean wheel speed over cruising samples, m/s^2;
        NaN without a wheel stream or with fewer than 20 cruising samples.
    """
    wheels = run.streams.get("wheels")
    if wheels is None or len(wheels) < 21:
        return float("nan")
    t = wheels[TIME].to_numpy(dtype=float)
    v = 0.5 * (wheels["vel_l"].to_numpy(dtype=float) + wheels["vel_r"].to_numpy(dtype=float))
    dt = np.diff(t)
    ok = dt > 0
    a = np.diff(v)[ok] / dt[ok]
    cruising = (np.abs(0.5 * (v[1:] + v[:-1])) >= min_speed_m_s)[ok]
    return float(np.sqrt(np.mean(a[cruising] ** 2))) if cruising.sum() >= 20 else float("nan")


def speed_resolution(values: np.ndarray, tol: float = 0.01) -> float:
    """Resolution step of a quantised speed record (0 when it is not quantised).

    Parameters
    ----------
    values : ndarray, shape (n,)
        Speeds, m/s.
    tol : float
        Largest deviation from an integer multiple of the step, in steps.

    Returns
    -------
    float
        The smallest step between distinct magnitudes when every magnitude is an integer
        multiple of it (BorealTC: 0.2/25.4 m/s), else 0.
    """
    v = np.unique(np.round(np.abs(np.asarray(values, dtype=float)), 7))
    v = v[v > 0]
    if v.size < 3:
        return 0.0
    step = float(np.min(np.diff(np.r_[0.0, v])))
    if step <= 1e-6:
        return 0.0
    k = v / step
    return step if np.all(np.abs(k - np.round(k)) < tol) else 0.0


def require_ordered(run: Run, stream: str) -> None:
    """Refuse a stream whose times do not strictly increase (the :class:`~terrain.run.Run`
    contract): ``numpy.interp``, which puts the replay's inputs and the IMU on the comparison
    clock, does not check its abscissae and returns values from the wrong time.

    Parameters
    ----------
    run : Run
        The run (``stream`` present, ``t_s`` finite: :meth:`~terrain.run.Run.require_finite`
        first).
    stream : str
        Stream name, a key of ``run.streams``.

    Raises
    ------
    TimestampError
        A time equal to or before the previous one (run, stream, count and first row named;
        a :class:`~terrain.errors.DataFormatError`).
    """
    t = run.streams[stream][TIME].to_numpy(dtype=float)
    bad = times_out_of_order(t)
    if bad.size:
        i = int(bad[0])
        raise TimestampError(f"run {run.run_id}: {stream} time {t[i]} at row {i} does not "
                             f"follow the previous one ({t[i - 1]}); {bad.size} such row(s): "
                             "the audit needs strictly increasing times", run.source, TIME, i)


def require_replayable(run: Run, terrain: TerrainParams | None = None) -> str:
    """The checks of :func:`replay_run` on its inputs, without replaying.

    Parameters
    ----------
    run : Run
        The run to replay.
    terrain : TerrainParams, optional
        Terrain to replay on instead of the catalogue entry of ``run.terrain``.

    Returns
    -------
    str
        The vehicle name (lower case), one of :data:`SKID_STEER_VEHICLES`.

    Raises
    ------
    ConfigError, DataFormatError
        As :func:`replay_run`.
    """
    vehicle_name = str(run.vehicle).lower()
    if vehicle_name not in SKID_STEER_VEHICLES:
        raise ConfigError(f"the audit replays skid-steer vehicles only "
                          f"({', '.join(SKID_STEER_VEHICLES)}), run {run.run_id} is "
                          f"{run.vehicle!r}")
    if terrain is None:
        if run.terrain is None:
            raise ConfigError(f"run {run.run_id} has no terrain label")
        get_terrain(run.terrain)
    wheels = run.streams.get("wheels")
    if wheels is None:
        raise DataFormatError(f"run {run.run_id} has no wheel stream", run.source)
    run.require_columns("wheels", ("vel_l", "vel_r", "cur_l", "cur_r"))
    if len(wheels) < 4:
        raise DataFormatError(f"run {run.run_id} has {len(wheels)} wheel samples (need 4)",
                              run.source)
    run.require_finite("wheels", ("vel_l", "vel_r", "cur_l", "cur_r"))
    require_ordered(run, "wheels")
    return vehicle_name


def replay_run(run: Run, settings: ReplaySettings = ReplaySettings(),
               terrain: TerrainParams | None = None) -> Replay:
    """Replay one measured run through the simulator (see the module docstring).

    Parameters
    ----------
    run : Run
        Needs a ``wheels`` stream (``t_s, vel_l, vel_r, cur_l, cur_r``).
    settings : ReplaySettings
    terrain : TerrainParams, optional
        Terrain parameters to use instead of the catalogue entry of ``run.terrain`` (e.g. a
        what-if lateral friction).

    Returns
    -------
    Replay

    Raises
    ------
    ConfigError
        Vehicle not a skid-steer, or terrain label unknown to the catalogue.
    DataFormatError
        No wheel stream, or fewer than 4 wheel samples; a
        :class:`~terrain.errors.MissingColumnError` when it lacks one of its columns, a
        :class:`~terrain.errors.NonFiniteError` (run, column and first row named) when one
        of them holds a NaN or infinite value, a :class:`~terrain.errors.TimestampError`
        (:func:`require_ordered`) when its times do not strictly increase.
    """
    vehicle_name = require_replayable(run, terrain)
    if terrain is None:
        terrain = get_terrain(str(run.terrain))
    wheels = run.streams["wheels"]
    vehicle = get_vehicle(vehicle_name)
    geometry = vehicle.contact_geometry()
    t_w = wheels[TIME].to_numpy(dtype=float)
    vel_l = wheels["vel_l"].to_numpy(dtype=float)
    vel_r = wheels["vel_r"].to_numpy(dtype=float)
    if settings.input_cutoff_hz is not None:
        wheel_rate_hz = run.rate_hz("wheels")   # the run's own rate (median step)
        vel_l = lowpass(vel_l, wheel_rate_hz, settings.input_cutoff_hz)
        vel_r = lowpass(vel_r, wheel_rate_hz, settings.input_cutoff_hz)
    dt = 1.0 / float(settings.physics_rate_hz)
    # the physics on the run's own clock from its first sample, ``k dt`` exactly: on an
    # epoch clock ``t0 + k dt`` rounded at 1.7e9 s (2.4e-7 s apart), the integrator's step,
    # read from the grid's first two times, was 0.005 s +- 1.1e-7 and the replay's time
    # ran 2.3e-5 off the wheel clock (82 ms per hour at 200 Hz)
    rel_w = t_w - t_w[0]
    t = np.arange(int(np.floor(rel_w[-1] / dt)) + 2) * dt
    in_l, in_r = vel_l, vel_r
    step = speed_resolution(np.r_[vel_l, vel_r]) if settings.merge_subresolution else 0.0
    if step > 0:
        tie = np.abs(vel_r - vel_l) <= 1.01 * step
        mean = 0.5 * (vel_l + vel_r)
        in_l, in_r = np.where(tie, mean, vel_l), np.where(tie, mean, vel_r)
    # the command of the step from t_k is the speed measured at its end, t_k + dt: the
    # motor (time constant dt) reaches its command at the end of a step, so the replayed
    # wheel at t_k is the measured one there (row k of the integrator is the plant at t_k)
    vl = np.interp(t + dt, rel_w, in_l)
    vr = np.interp(t + dt, rel_w, in_r)
    b = float(vehicle.track_m)
    # the body twist the measured sides command (seed 000 eq. 2, the one skid-steer relation
    # of terrain.vehicles), which the simulator's wheel_commands turns back into vl, vr
    v, w = skid_steer_forward(vl, vr, b)
    twist = np.column_stack([v, np.zeros_like(t), w])
    r_w = geometry.wheel_radius_m
    vmax = max(float(np.max(np.abs(np.r_[vel_l, vel_r]))), 1e-3)
    motor = replace(vehicle.motor, speed_time_constant_s=dt,
                    max_wheel_speed_rad_s=max(vehicle.motor.max_wheel_speed_rad_s,
                                              settings.speed_headroom * vmax / r_w))
    replayed = replace(vehicle, motor=motor)
    phys = integrate(replayed, geometry, (terrain,), 1e12, t, twist, 0.0, 1.0,
                     physics=settings.physics)
    cur = reported_current_a(vehicle.motor, phys.torque, phys.omega, settings.physics)
    out = np.column_stack([phys.twist[:, 2], phys.accel_body, phys.twist[:, 0], cur])
    out = lowpass(out, settings.physics_rate_hz, settings.output_cutoff_hz)
    # the currents are magnitudes: the zero-phase filter's ringing (and its odd extension at
    # the ends) dips below 0 where a current rises from rest; that dip is the filter's, not
    # the motor's
    out[:, 4:6] = np.maximum(out[:, 4:6], 0.0)
    sampled = np.column_stack([np.interp(rel_w, t, out[:, j]) for j in range(out.shape[1])])
    return Replay(run_id=run.run_id, terrain=terrain.name, vehicle=vehicle_name, track_m=b,
                  t_s=t_w, vel_l=vel_l, vel_r=vel_r, yaw_rate=sampled[:, 0],
                  ax=sampled[:, 1], ay=sampled[:, 2], v_x=sampled[:, 3],
                  cur=sampled[:, 4:6])
