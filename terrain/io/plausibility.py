"""Physical plausibility of measured streams: value ranges, unit and clock rules, stuck sensors.

Robot logs go wrong in ordinary ways (a driver publishing the gyro in deg/s, wheel speeds in
km/h, timestamps in ms, two clocks with different epochs, a dead sensor). The readers of
:mod:`terrain.io` apply the rules below to every run they load. A rule whose evidence is
*certain* raises a typed error naming the rule, its evidence and the likely fix; a rule whose
evidence is only *likely* emits a :class:`~terrain.errors.DataWarning` saying what the reader
assumed. Nothing is ever rescaled.

Ranges (:data:`CHANNEL_LIMITS`, refuse beyond them, any vehicle)
    * angular rate ``|w| <= 34.9 rad/s``: 2000 deg/s, the largest full-scale range of common
      MEMS gyroscopes (Bosch BMI088 and InvenSense MPU-9250 datasheets);
    * specific force ``|a| <= 235.4 m/s^2``: 24 g, the largest full-scale range of the BMI088
      accelerometer (the shipped runs peak at 140 m/s^2 in shocks);
    * wheel speed ``|v| <= 5 m/s`` and motor current ``|i| <= 1000 A``: an order of magnitude
      above every vehicle of :mod:`terrain.vehicles` (top speeds 0.5 to 1.6 m/s); the
      vehicle-specific bounds of :data:`VEHICLE_LIMITS` are stricter.

Vehicle bounds (:data:`VEHICLE_LIMITS`, Clearpath Husky A200, the robot of the measured data)
    * top speed 1.0 m/s and yaw rate 2.0 rad/s: Clearpath Husky datasheet, and the velocity
      limits of Clearpath's ``husky_control/config/control.yaml`` (``max_velocity`` 1.0 m/s
      linear, 2.0 rad/s angular); the same top speed is the motor limit of
      :data:`terrain.vehicles.HUSKY`;
    * motor current 80 A: the Husky A200 user manual (Clearpath, 2014, p. 12) rates the
      motors at 8 A continuous "but they will spike to several times this"; the shipped runs
      peak at 32.6 A. ASSUMED bound: ten times the continuous rating; a current beyond
      it is warned about (rule ``current_range``).

Unit and clock rules (:func:`check_run`)
    ``timestamp_units``
        The sample rate implied by the median time step against the nominal rate range of
        the stream (:data:`NOMINAL_RATE_HZ`). Certain (refuse) when the implied rate is ten
        times below the range and 1000, 10^6 or 10^9 x the implied rate falls inside it: the
        timestamps are in ms, us or ns (:func:`timestamp_unit`; us and ns were once only
        warned about and read as s, and ``terrain predict`` then ran out of memory); likely
        (warning, assumed s) when the rate is outside the range otherwise.
    ``clock_overlap``
        The time spans of the streams of a run must overlap (both measured files start at
        ``time = 0``). Certain when they do not overlap at all (e.g. an epoch clock beside a
        clock from 0); likely (warning) when they overlap for less than half of the shorter,
        or when one stream runs on for more than :data:`MAX_UNUSED_SPAN_S` (or a tenth of the
        overlap, whichever is longer) before or after the other (a truncated file): only the
        overlap is used, and the message gives the seconds of each stream left out (the
        shipped runs: at most 1.34 s). The seconds of each stream outside the other's span
        are counted whether warned about or not (``Run.meta["unused_s"]``, shown by the
        input report of every command: 20.4 s of IMU beside a wheel file cut at 236 s of
        256 s are under a tenth of the overlap, left out without a warning).
    ``gyro_units``
        Yaw rate of the gyro against the difference of the wheel speeds (vehicles of
        :data:`VEHICLE_LIMITS`, skid-steer): for a skid-steer
        vehicle ``wz = (v_R - v_L) / (chi B)`` (ICR model, :mod:`terrain.vehicles.skid_steer`)
        so the least-squares slope ``k`` of ``wz`` on ``v_R - v_L`` is ``1 / (chi B)``,
        at most :data:`MAX_YAW_SLOPE_PER_M` (track ``B >= 0.2 m``, ``chi >= 1``; the shipped
        runs give at most 1.5 1/m). A gyro in deg/s multiplies ``k`` by 57.3. Certain when the
        wheels do turn (std of ``v_R - v_L`` >= 0.02 m/s), the correlation is >= 0.5 and ``k``
        exceeds :data:`DEG_S_SLOPE_PER_M`. Likely when the median standard deviation of the
        three gyro axes exceeds :data:`MAX_GYRO_SPREAD_RAD_S` (the shipped runs: at most
        0.18 rad/s; their straight runs converted to deg/s: 0.33 to 10), or the yaw rate
        exceeds twice the vehicle's limit.
    ``wheel_sides``
        The left and right wheel columns against the gyro (vehicles of
        :data:`VEHICLE_LIMITS`, skid-steer): ``wz`` rises with ``v_R - v_L`` (the format's
        frame: ``wz > 0`` turning left, when the right side runs faster), so swapped columns
        make the yaw rate fall as the difference rises. Judged on means over
        :data:`WHEEL_SIDES_BLOCK_S` blocks of the wheel samples inside the gyro's span, when
        the wheels do turn (as for ``gyro_units``) over at least
        :data:`WHEEL_SIDES_MIN_BLOCKS` blocks: certain (refuse) when the correlation of the
        block means is <= -0.5 and the Fisher z of the correlation of their block-to-block
        *changes* is at most :data:`WHEEL_SIDES_Z` (the changes remove slow drifts, which
        correlate two independent signals by chance; the z counts the changes' samples as
        ``m / (1 + 2 r_a r_b)`` with their lag-1 autocorrelations ``r_a``, ``r_b``, Bartlett
        1935). Independent signals, white to random walks, 10 s to 10 min at 6.5-50 Hz,
        were refused in none of 35 000 draws (lowest z -4.4; ``tests/io/test_wheel_sides.py``
        draws more); of the 28 shipped runs judged, none comes near (lowest z -3.5, lowest
        correlation of the block means -0.18), and 8 of the 23 BorealTC ones are refused
        with their sides swapped (the others, and Vulpi's 5, turn too little or too smoothly
        to tell). Served requests of a few seconds are too short to be judged.
    ``wheel_speed_units``
        Husky wheel speeds against the top speed: a wheel cannot turn faster than the motor
        limit (top speed), so a 99th percentile above twice the top speed is certain (km/h is
        3.6 x m/s); above 1.2 x the top speed it is likely. Against the accelerometer: the
        slope of the wheel-speed derivative on the forward specific force (1 s averages) is
        about 1 in m/s (the shipped runs: at most 0.5, the IMU axes being tilted); when the
        correlation is >= 0.5 and the slope exceeds 2.5 the speeds are likely in km/h.
    ``current_range``
        Motor currents against the vehicle's bound (vehicles of :data:`VEHICLE_LIMITS`,
        80 A for the Husky). The bound is assumed, so any sample beyond it is likely
        (warning, assumed A): a current in another unit or scale; the 1000 A range of
        :data:`CHANNEL_LIMITS` refuses.
    ``accel_units`` (:func:`check_accel_units`, on the IMU file alone)
        The median norm of the specific force at rest and in motion is gravity: 9.81 in
        m/s^2, 1 in g. Judged on the samples outside the accelerometer's stuck stretches
        (rule ``stuck_sensor``; a dead, all-zero accelerometer is that rule's warning, not a
        unit error). Certain (refuse) when the median is in
        [:data:`DEAD_ACCEL_M_S2`, :data:`G_UNITS_BELOW_M_S2`) = [0.5, 3): the file is in g.
        Below 0.5 the sensor sees no gravity in either unit: a dead or disconnected
        accelerometer, a warning (assumed m/s^2).
    ``imu_axes``
        The body frame of the format is x forward, y left, z up (:mod:`terrain.run`): on
        level ground ``az`` is +9.81 m/s^2, the ``g cos(pitch)`` of the filters'
        accelerometer model (:mod:`terrain.estimation.skid_steer_slip`). Certain (refuse)
        when the median ``az`` of the live samples (as for ``accel_units``) is below
        :data:`Z_DOWN_BELOW` times their median specific force, itself gravity in m/s^2
        (at least :data:`G_UNITS_BELOW_M_S2`): the z axis points down (a z-down frame, x
        forward, y right, z down, as PX4 logs it), which turns ``wy``, ``wz`` and ``ay``
        too; a ground vehicle does not drive pitched or rolled beyond 120 degrees (the
        shipped runs: at least +0.87). Any vehicle.
    ``stuck_sensor``
        A channel that holds one exact value for long is a dead or stuck sensor: IMU channels
        for :data:`STUCK_IMU_S` (a live MEMS sensor never repeats a float for more than 2
        samples in the shipped runs), motor currents for :data:`STUCK_CURRENT_S` (shipped
        runs: at most 12.5 s, at standstill). Wheel speeds are not judged this way: quantised
        speeds legitimately hold one value for minutes at cruise. Stuck stretches are reported
        (``Run.meta["stuck"]``) and windows holding one are flagged by the commands.
"""

from __future__ import annotations

import math
import warnings
from dataclasses import dataclass
from types import MappingProxyType
from typing import Mapping, Sequence

import numpy as np
import pandas as pd

from terrain.errors import (ClockError, DataWarning, ImplausibleValueError, UnitError,
                            first_items)
from terrain.io.report import seconds_text
from terrain.run import IMU_CHANNELS, TIME


@dataclass(frozen=True)
class ChannelLimit:
    """Largest plausible magnitude of a channel.

    Parameters
    ----------
    limit : float
        Largest plausible ``|value|`` in ``unit``.
    unit : str
        SI unit of the channel.
    source : str
        Where the bound comes from.
    hint : str
        Likely cause and fix, appended to the message.
    """

    limit: float
    unit: str
    source: str
    hint: str = ""


_GYRO = ChannelLimit(math.radians(2000.0), "rad/s",
                     "2000 deg/s MEMS gyro full scale (BMI088, MPU-9250 datasheets)",
                     "the file looks like deg/s, expected rad/s")
_ACC = ChannelLimit(24 * 9.80665, "m/s^2", "24 g MEMS accelerometer full scale (BMI088)")
_SPEED = ChannelLimit(5.0, "m/s", "5 x the fastest vehicle of terrain.vehicles")
_CURRENT = ChannelLimit(1000.0, "A", "far above any motor of terrain.vehicles")

#: canonical channel -> plausibility bound (any vehicle)
CHANNEL_LIMITS: Mapping[str, ChannelLimit] = MappingProxyType({
    "wx": _GYRO, "wy": _GYRO, "wz": _GYRO, "ax": _ACC, "ay": _ACC, "az": _ACC,
    "vel_l": _SPEED, "vel_r": _SPEED, "cur_l": _CURRENT, "cur_r": _CURRENT,
})


@dataclass(frozen=True)
class VehicleLimits:
    """Datasheet bounds of one vehicle used by the unit rules.

    Parameters
    ----------
    top_speed_m_s : float
        Top speed, m/s.
    max_yaw_rate_rad_s : float
        Largest commanded yaw rate, rad/s.
    max_current_a : float
        Largest plausible motor current, A.
    source : str
        Where the figures come from.
    """

    top_speed_m_s: float
    max_yaw_rate_rad_s: float
    max_current_a: float
    source: str


VEHICLE_LIMITS: Mapping[str, VehicleLimits] = MappingProxyType({
    "husky": VehicleLimits(1.0, 2.0, 80.0,
                           "Clearpath Husky A200 datasheet and husky_control/config/"
                           "control.yaml (1.0 m/s, 2.0 rad/s); user manual 2014 p. 12 "
                           "(8 A continuous, spikes several times; 80 A ASSUMED)"),
})

#: longest stretch of one stream outside the overlap of a run's streams that passes without a
#: ``clock_overlap`` warning, s (or a tenth of the overlap, whichever is longer); the shipped
#: runs' streams end at most 1.34 s apart (BorealTC ICE/00)
MAX_UNUSED_SPAN_S = 2.0

#: stream -> (lowest, highest) nominal sample rate, Hz (MEMS IMUs 10-2000 Hz; Husky wheel
#: reports 6.5-15 Hz in the shipped data, simulator streams up to 100 Hz)
NOMINAL_RATE_HZ: Mapping[str, tuple[float, float]] = MappingProxyType({
    "imu": (10.0, 2000.0), "wheels": (1.0, 1000.0)})
#: units a clock read as s may be in (rule ``timestamp_units``): unit -> (units per second,
#: name, the divisor as the messages print it); tried in this order
TIME_UNITS: Mapping[str, tuple[float, str, str]] = MappingProxyType({
    "ms": (1e3, "milliseconds", "1000"), "us": (1e6, "microseconds", "1e6"),
    "ns": (1e9, "nanoseconds", "1e9")})
#: largest plausible slope of wz on v_R - v_L, 1/m (1 / (chi B) with B >= 0.2 m, chi >= 1)
MAX_YAW_SLOPE_PER_M = 5.0
#: slope beyond which the gyro is certainly in deg/s (57.3 x the smallest rad/s slope seen,
#: 0.3 1/m, is 17 1/m)
DEG_S_SLOPE_PER_M = 15.0
#: median standard deviation of the gyro axes above which a gyro is probably in deg/s, rad/s
MAX_GYRO_SPREAD_RAD_S = 0.3
#: block over which the wheel-side rule averages wheel speeds and yaw rate, s: long enough
#: to average the wheels' quantisation and the gyro's vibration, short enough that a 3 s
#: turn gives several blocks (rule ``wheel_sides``)
WHEEL_SIDES_BLOCK_S = 1.0
#: fewest blocks the wheel-side rule judges on
WHEEL_SIDES_MIN_BLOCKS = 8
#: Fisher z of the block changes' correlation at or below which the wheel sides are
#: certainly swapped (one-sided normal tail 1e-9; drawn independent signals: lowest -4.4)
WHEEL_SIDES_Z = -6.0
#: seconds of one exact repeated value after which a channel is stuck
STUCK_IMU_S = 1.0
STUCK_CURRENT_S = 20.0
#: samples of one exact value a stuck stretch needs besides its duration (a slow stream's
#: few repeats are not one)
STUCK_MIN_SAMPLES = 10
#: slack of the rules' bounds on durations, s (the stuck rule's, ``clock_overlap``'s): a
#: duration equal to a bound to within the float rounding of its timestamps (1e-16 s of a
#: clock from 0, 2.4e-7 s of an epoch clock at 1.7e9 s) is on the bound
TIME_SLACK_S = 1e-6


def stuck_limit_s(stream: str, channel: str) -> float | None:
    """Seconds of one repeated value after which ``channel`` is stuck (rule
    ``stuck_sensor``), or None when the rule does not judge it.

    Parameters
    ----------
    stream : str
        Stream name: only ``imu`` channels and ``wheels`` currents are judged by the readers;
        a stream of another name (a regrouping in the streaming service) is judged by its
        channel names alone.
    channel : str
        Channel name.

    Returns
    -------
    float or None
        :data:`STUCK_IMU_S` for the IMU channels, :data:`STUCK_CURRENT_S` for the motor
        currents, None otherwise (wheel speeds hold quantised values for minutes).
    """
    if channel in IMU_CHANNELS and stream != "wheels":
        return STUCK_IMU_S
    if channel in ("cur_l", "cur_r") and stream != "imu":
        return STUCK_CURRENT_S
    return None


def is_stuck(duration_s: float, n_samples: int, limit_s: float) -> bool:
    """Whether a stretch of one exact value is a stuck sensor (rule ``stuck_sensor``).

    Parameters
    ----------
    duration_s : float or numpy.ndarray
        From the stretch's first to its last sample, s (one per stretch).
    n_samples : int or numpy.ndarray
        Samples in the stretch (one per stretch).
    limit_s : float
        :func:`stuck_limit_s` of the channel, s.

    Returns
    -------
    bool or numpy.ndarray
        ``duration_s >= limit_s`` and at least :data:`STUCK_MIN_SAMPLES` samples, per
        stretch; a duration short of the limit by at most :data:`TIME_SLACK_S` (the
        timestamps' rounding: 51 samples of a 50 Hz clock span 0.9999999999999998 s
        for one start in six) counts as the limit.
    """
    return ((np.asarray(duration_s) >= limit_s - TIME_SLACK_S)
            & (np.asarray(n_samples) >= STUCK_MIN_SAMPLES))


#: median specific-force norm below which an accelerometer is in g (gravity reads 1 in g,
#: 9.81 in m/s^2), m/s^2
G_UNITS_BELOW_M_S2 = 3.0
#: median specific-force norm below which an accelerometer sees no gravity in either unit
#: (half of gravity in g): a dead sensor, not a unit mistake, m/s^2
DEAD_ACCEL_M_S2 = 0.5
#: median ``az`` over the median specific-force norm below which the IMU's z axis points
#: down (rule ``imu_axes``: more than 120 degrees from up; the shipped runs: >= 0.87)
Z_DOWN_BELOW = -0.5
_ACCEL = ("ax", "ay", "az")


def accel_in_g(median_specific_force: float) -> bool:
    """Whether a median specific force, m/s^2, says the accelerometer is in g (rule
    ``accel_units``): in [:data:`DEAD_ACCEL_M_S2`, :data:`G_UNITS_BELOW_M_S2`), far below
    gravity's 9.81 but above a dead sensor's.

    Parameters
    ----------
    median_specific_force : float
        Median of ``|(ax, ay, az)|`` over live samples, in the stream's units.

    Returns
    -------
    bool
    """
    return DEAD_ACCEL_M_S2 <= median_specific_force < G_UNITS_BELOW_M_S2


def check_accel_units(frame: pd.DataFrame, path, found: list[str] | None = None) -> None:
    """Rule ``accel_units``: an accelerometer in g, told apart from a dead one.

    Parameters
    ----------
    frame : pandas.DataFrame
        IMU frame (``t_s``, ``ax``, ``ay``, ``az`` in the file's units, supposedly m/s^2).
    path : str or Path
        File (for the message).
    found : list of str, optional
        Where the dead-sensor warning goes (the reader's :class:`ReadReport` warnings, which
        it warns and the run keeps); None: warned here as a :class:`DataWarning`.

    Raises
    ------
    UnitError
        When the live samples' median specific force is in [0.5, 3) m/s^2: the file is in g.
    """
    acc = frame[list(_ACCEL)].to_numpy(dtype=float)
    live = _live_accel(frame)
    if not live.any():
        return  # every sample in a stuck stretch: the stuck_sensor rule reports it
    median = float(np.median(np.linalg.norm(acc[live], axis=1)))
    if median < DEAD_ACCEL_M_S2:
        _warn(f"{path}: rule accel_units: median specific force {median:.2f} over "
              f"{int(live.sum())} sample(s) outside stuck stretches: the accelerometer sees "
              "no gravity (9.81 m/s^2, or 1 in g): dead or disconnected sensor; assumed "
              "m/s^2", found)
    elif accel_in_g(median):
        raise UnitError(f"rule accel_units: median specific force {median:.2f} is far below "
                        "9.81 m/s^2; the file looks like units of g, expected m/s^2 (x 9.81)",
                        path, "az")


def _live_accel(frame: pd.DataFrame) -> np.ndarray:
    """``(n,)`` bool: the IMU rows outside its accelerometer's stuck stretches (rule
    ``stuck_sensor``), on which the accelerometer rules judge it."""
    live = np.ones(len(frame), dtype=bool)
    t = frame[TIME].to_numpy()
    for spans in stuck_stretches({"imu": frame[[TIME, *_ACCEL]]}).values():
        for a, b in spans:
            live &= ~((t >= a) & (t <= b))
    return live


def _check_imu_axes(imu: pd.DataFrame, path) -> None:
    """Rule ``imu_axes``: UnitError for an IMU whose z axis points down (every consumer
    takes ``az = g cos(pitch) > 0`` and ``wz > 0`` turning left)."""
    if not all(c in imu.columns for c in _ACCEL):
        return
    acc = imu[list(_ACCEL)].to_numpy(dtype=float)
    live = _live_accel(imu) & np.isfinite(acc).all(axis=1)
    if not live.any():
        return
    median = float(np.median(np.linalg.norm(acc[live], axis=1)))
    if median < G_UNITS_BELOW_M_S2:     # in g, or dead: rule accel_units'
        return
    az = float(np.median(acc[live, 2]))
    if az < Z_DOWN_BELOW * median:
        raise UnitError(f"rule imu_axes: median az {az:.2f} m/s^2 against a median specific "
                        f"force of {median:.2f}: the IMU's z axis points down (a z-down frame, "
                        "x forward, y right, z down?); the format's body frame is x forward, "
                        "y left, z up (az +9.81 on level ground, wz > 0 turning left): negate "
                        "wy, wz, ay and az", path, "az")


def check_ranges(frame: pd.DataFrame, path, columns: Mapping[str, str],
                 lines: np.ndarray | None = None,
                 limits: Mapping[str, ChannelLimit] = CHANNEL_LIMITS,
                 rows: np.ndarray | None = None) -> None:
    """Refuse values outside the plausibility range of their channel.

    Float, integer and unsigned columns are judged (a column of another kind, e.g. text,
    is the reader's to refuse as non-numeric).

    Parameters
    ----------
    frame : pandas.DataFrame
        Stream frame with canonical channel names (SI units).
    path : str or Path
        File the frame was read from (for the message).
    columns : Mapping[str, str]
        Column name in the file -> canonical name (as
        :data:`terrain.io.measured.COLUMN_MAPS`), so the error names the file's column.
    lines : numpy.ndarray, optional
        ``(n_rows,)`` 1-based file line of each row.
    limits : Mapping[str, ChannelLimit]
        Bounds per canonical channel.
    rows : numpy.ndarray, optional
        ``(n_rows,)`` 0-based data row of each row where the frame is one stream cut from a
        larger table (a served model's request); default: the frame's own positions.

    Raises
    ------
    ImplausibleValueError
        Naming file, column, the first offending lines (or rows) and their count.
    """
    file_col = {v: k for k, v in columns.items()}
    for name, lim in limits.items():
        if name not in frame.columns or frame[name].dtype.kind not in "iuf":
            continue
        values = frame[name].to_numpy()
        # both bounds, not abs(): int64's most negative value is its own abs (NaN: neither)
        bad = np.flatnonzero((values > lim.limit) | (values < -lim.limit))
        if bad.size:
            at = bad if rows is None else np.asarray(rows)[bad]
            where = lines[bad] if lines is not None else at
            raise ImplausibleValueError(
                f"{bad.size} value(s) beyond +-{lim.limit:.4g} {lim.unit} ({lim.source}), "
                f"first {values[bad[0]]:.6g} at "
                f"{first_items(where, word='line' if lines is not None else 'row')}"
                + (f"; {lim.hint}" if lim.hint else ""),
                path, file_col.get(name, name), int(at[0]),
                int(where[0]) if lines is not None else None)


def implied_rate_hz(t_s: np.ndarray) -> float:
    """Sample rate implied by the median time step, Hz, to 4 significant digits.

    Judged as printed: float steps of 1 ms give 1000.0000000006 Hz, which is the nominal
    bound of 1000 Hz, not outside it.

    Parameters
    ----------
    t_s : numpy.ndarray
        ``(n,)`` increasing timestamps, s (``n >= 2``).

    Returns
    -------
    float
        ``1 / median(diff(t_s))`` rounded to 4 significant digits, Hz.
    """
    return float(f"{1.0 / float(np.median(np.diff(t_s))):.4g}")


def timestamp_unit(rate_hz: float, stream: str) -> str | None:
    """Rule ``timestamp_units``'s certain case: the unit of timestamps read as s that are
    not (ms, us or ns). The one place the readers (:func:`check_rate`) and the streaming
    service (:func:`terrain.serving.clocks.clock_in_ms`) judge it.

    Parameters
    ----------
    rate_hz : float
        Sample rate implied by the median time step (:func:`implied_rate_hz`), Hz.
    stream : str
        Stream name (``imu``, ``wheels``; any other is never judged).

    Returns
    -------
    str or None
        The first key of :data:`TIME_UNITS` (``"ms"``, ``"us"``, ``"ns"``) whose units per
        second times the rate fall inside the stream's nominal range
        (:data:`NOMINAL_RATE_HZ`, judged to 4 significant digits, as printed), when the
        rate is ten times below that range; None otherwise (s, or no unit explains it).
    """
    if stream not in NOMINAL_RATE_HZ:
        return None
    lo, hi = NOMINAL_RATE_HZ[stream]
    if not rate_hz < lo / 10.0:
        return None
    return next((unit for unit, (per_s, _, _) in TIME_UNITS.items()
                 if lo <= float(f"{per_s * rate_hz:.4g}") <= hi), None)


def check_rate(t_s: np.ndarray, stream: str, path, time_column: str = "time",
               found: list[str] | None = None) -> None:
    """Rule ``timestamp_units``: implied sample rate against the stream's nominal rate.

    Parameters
    ----------
    t_s : numpy.ndarray
        ``(n,)`` timestamps as read, supposedly s.
    stream : str
        Stream name (``imu``, ``wheels``; others are not judged).
    path : str or Path
        File (for the message).
    time_column : str
        Name of the time column where the timestamps were read (for the message: ``time``
        in the measured files, ``t_s`` in a served model's request).
    found : list of str, optional
        Where the warning of a rate outside the nominal range goes (as for
        :func:`check_accel_units`); None: warned here.

    Raises
    ------
    UnitError
        When the timestamps are certainly in ms, us or ns (:func:`timestamp_unit`), naming
        the file, the time column and the unit.
    """
    if stream not in NOMINAL_RATE_HZ or t_s.size < 2:
        return
    lo, hi = NOMINAL_RATE_HZ[stream]
    rate = implied_rate_hz(t_s)
    unit = timestamp_unit(rate, stream)
    if unit is not None:
        per_s, word, factor = TIME_UNITS[unit]
        raise UnitError(
            f"rule timestamp_units: median step implies {rate:.4g} Hz, far below the "
            f"{lo:g}-{hi:g} Hz of the {stream} stream; x{factor} gives {per_s * rate:.4g} Hz: "
            f"the timestamps look like {word} ({unit}); divide the time column by {factor}",
            path, time_column)
    if not lo <= rate <= hi:
        _warn(f"{path}: rule timestamp_units: column {time_column!r}: implied sample rate "
              f"{rate:.4g} Hz outside the nominal {lo:g}-{hi:g} "
              f"Hz of the {stream} stream; timestamps assumed in s", found)


def check_run(run_id: str, streams: Mapping[str, pd.DataFrame], vehicle: str,
              files: Mapping[str, str], time_column: str = "time",
              columns: Mapping[str, Mapping[str, str]] | None = None, *,
              warn: bool = True) -> dict:
    """Apply the clock, unit and stuck-sensor rules to the streams of one run.

    Parameters
    ----------
    run_id : str
        Run id (for the messages of a stream that ``files`` does not name).
    streams : Mapping[str, pandas.DataFrame]
        Stream name -> frame (``t_s`` first, canonical channels, SI units).
    vehicle : str
        Vehicle name; the vehicle rules apply to vehicles of :data:`VEHICLE_LIMITS`.
    files : Mapping[str, str]
        Stream name -> file or source (for the messages).
    time_column : str
        Name of the streams' time column where they were read (for the messages).
    columns : Mapping[str, Mapping[str, str]], optional
        Stream name -> {file column -> canonical channel} where the file's column names
        differ from the channels' (:data:`terrain.io.measured.COLUMN_MAPS`), so that a
        stuck-sensor warning (``column 'curL' (wheels.cur_l)``) and the wheel-speed unit
        error name the columns of the file; None: the files use the canonical names (the
        shipped Parquet files, a served request).
    warn : bool, optional
        Warn each finding as a :class:`DataWarning` (the readers); False: return them only
        (:func:`terrain.io.writer.write_run`, which refuses what the readers would refuse and
        leaves the findings to the readers, who warn them on every read).

    Returns
    -------
    dict
        ``{"stuck": {"<stream>.<channel>": [[t_start_s, t_end_s], ...]},
        "unused_s": {"imu": s, "wheels": s}, "warnings": [str, ...]}``, JSON-ready;
        ``unused_s`` holds the seconds of each stream before or after the other's span
        (rule ``clock_overlap``; left out wherever both streams are aligned), only those
        above 0, empty without both streams.

    Raises
    ------
    ClockError
        Streams whose time spans do not overlap.
    UnitError
        An IMU whose z axis points down (rule ``imu_axes``), a gyro certainly in deg/s,
        left and right wheel columns certainly swapped (rule ``wheel_sides``), wheel speeds
        certainly in km/h.
    """
    found: list[str] = []
    unused: dict[str, float] = {}
    imu, wheels = streams.get("imu"), streams.get("wheels")
    src = (lambda s: files.get(s, run_id))
    if imu is not None and len(imu):
        _check_imu_axes(imu, src("imu"))
    if imu is not None and wheels is not None and len(imu) and len(wheels):
        clocks = _check_clocks(imu, wheels, src, found, time_column)
        unused = {k: v for k, v in clocks.items() if v > 0}
        _check_gyro(imu, wheels, vehicle, src("imu"), found, src("wheels"),
                    [_file_column("wheels", c, columns)
                     for c in ("vel_l", "vel_r", "cur_l", "cur_r")])
    if wheels is not None and len(wheels) and vehicle in VEHICLE_LIMITS:
        _check_wheel_speed(wheels, imu, VEHICLE_LIMITS[vehicle], src("wheels"), found,
                           [_file_column("wheels", c, columns) for c in ("vel_l", "vel_r")])
        _check_current(wheels, VEHICLE_LIMITS[vehicle], src("wheels"), found, columns)
    stuck = stuck_stretches(streams)
    for key, spans in stuck.items():
        total = sum(b - a for a, b in spans)
        found.append(f"{src(key.split('.')[0])}: {_channel_text(key, columns)} stuck at one "
                     f"value for {total:.1f} s "
                     f"({len(spans)} stretch(es), first from t = {spans[0][0]:.1f} s): dead "
                     "or stuck sensor; windows holding it are flagged")
    for msg in found if warn else ():
        _warn(msg)
    return {"stuck": stuck, "unused_s": unused, "warnings": found}


def _file_column(stream: str, channel: str,
                 columns: Mapping[str, Mapping[str, str]] | None) -> str:
    """The column of ``stream``'s file that holds ``channel`` (the channel's own name where
    ``columns`` gives none)."""
    return next((c for c, n in (columns or {}).get(stream, {}).items() if n == channel),
                channel)


def _channel_text(key: str, columns: Mapping[str, Mapping[str, str]] | None) -> str:
    """``<stream>.<channel>`` for a message, led by the file's column name where that
    differs (``column 'curL' (wheels.cur_l)``): the user looks for it in the file."""
    stream, channel = key.split(".", 1)
    column = _file_column(stream, channel, columns)
    return key if column == channel else f"column {column!r} ({key})"


def stuck_stretches(streams: Mapping[str, pd.DataFrame]) -> dict[str, list[list[float]]]:
    """Rule ``stuck_sensor``: stretches where a channel repeats one exact value for long.

    Parameters
    ----------
    streams : Mapping[str, pandas.DataFrame]
        Stream name -> frame; only ``imu`` channels and ``wheels`` currents are judged.

    Returns
    -------
    dict
        ``"<stream>.<channel>" -> [[t_start_s, t_end_s], ...]`` (only stuck channels).
    """
    out: dict[str, list[list[float]]] = {}
    for stream in ("imu", "wheels"):
        frame = streams.get(stream)
        if frame is None or len(frame) < 3:
            continue
        t = frame[TIME].to_numpy()
        for c in frame.columns:
            min_s = stuck_limit_s(stream, c)
            if min_s is None:
                continue
            x = frame[c].to_numpy()
            change = np.flatnonzero(np.diff(x) != 0)
            starts = np.r_[0, change + 1]
            ends = np.r_[change, x.size - 1]
            long = is_stuck(t[ends] - t[starts], ends - starts + 1, min_s)
            if long.any():
                out[f"{stream}.{c}"] = [[float(t[a]), float(t[b])]
                                        for a, b in zip(starts[long], ends[long])]
    return out


def _warn(message: str, found: list[str] | None = None) -> None:
    """A likely-wrong finding: into ``found`` when given (its owner warns it), else warned
    as a :class:`DataWarning` at the caller's caller."""
    if found is None:
        warnings.warn(message, DataWarning, stacklevel=3)
    else:
        found.append(message)


def _check_clocks(imu, wheels, src, found, time_column: str = "time") -> dict[str, float]:
    """Rule ``clock_overlap``; returns the seconds of each stream outside the other's span."""
    (a0, a1), (b0, b1) = ((float(f[TIME].iloc[0]), float(f[TIME].iloc[-1]))
                          for f in (imu, wheels))
    overlap = min(a1, b1) - max(a0, b0)
    spans = f"imu {a0:.10g}..{a1:.10g} s, wheels {b0:.10g}..{b1:.10g} s"
    if overlap <= 0:
        raise ClockError(f"rule clock_overlap: the IMU and wheel clocks do not overlap "
                         f"({spans}); both streams must start near time 0 (subtract each "
                         "stream's first timestamp, or fix the one in another unit or "
                         "epoch)", src("imu") if src("imu") == src("wheels")
                         else f"{src('imu')} and {src('wheels')}", time_column)
    shorter = min(a1 - a0, b1 - b0)
    unused = {"imu": (a1 - a0) - overlap, "wheels": (b1 - b0) - overlap}
    # (strict bounds, by more than the timestamps' rounding: 10.3 - 8.3 s is
    # 2.0000000000000018 s, which was warned of as more than 2 s)
    left_out = {k: v for k, v in unused.items()
                if v > max(MAX_UNUSED_SPAN_S, 0.1 * overlap) + TIME_SLACK_S}
    if (shorter > 0 and overlap < 0.5 * shorter - TIME_SLACK_S) or left_out:
        unused_text = ", ".join(f"{k} {seconds_text(v)}" for k, v in unused.items() if v > 0)
        found.append(f"{src('imu')}: rule clock_overlap: the IMU and wheel clocks overlap for "
                     f"{overlap:.1f} s only ({spans}); assumed one clock, only the overlap "
                     f"can be classified (left out: {unused_text}; a live replay or a served "
                     "request answers the rest with dropped, stale decisions)")
    return unused


def _check_gyro(imu, wheels, vehicle, path, found, wheels_path,
                wheel_columns: Sequence[str]) -> None:
    # finite samples only: a non-finite one is the non-finite rule's (an inf made the spread
    # and the percentile inf, "probably in deg/s"; a NaN the correlation NaN)
    gyro = [imu[c].to_numpy(float) for c in ("wx", "wy", "wz")]
    spread = float(np.median([np.std(g[np.isfinite(g)]) if np.isfinite(g).any() else 0.0
                              for g in gyro]))
    t_i = imu[TIME].to_numpy(float)
    ok = np.isfinite(t_i) & np.isfinite(gyro[2])
    t_w = wheels[TIME].to_numpy()
    inside = (t_w >= t_i[0]) & (t_w <= t_i[-1])
    dv = (wheels["vel_r"].to_numpy() - wheels["vel_l"].to_numpy())[inside]
    # skid-steer vehicles with datasheet bounds only: a steered vehicle's left/right wheel
    # speeds do not set its yaw rate
    if vehicle in VEHICLE_LIMITS and ok.sum() >= 2:
        wz = np.interp(t_w[inside], t_i[ok], gyro[2][ok])
        keep = np.isfinite(dv)
        dv, wz = dv[keep], wz[keep]
        if dv.size >= 10 and dv.std() >= 0.02:
            dv0, wz0 = dv - dv.mean(), wz - wz.mean()
            corr = _correlation(dv, wz)
            k = float(dv0 @ wz0) / float(dv0 @ dv0)
            if abs(corr) >= 0.5 and abs(k) > DEG_S_SLOPE_PER_M:
                raise UnitError(
                    f"rule gyro_units: slope of the yaw rate on the wheel speed difference "
                    f"is {k:.1f} 1/m (corr {corr:.2f}); a rad/s gyro gives 1 / (chi B), at "
                    f"most {MAX_YAW_SLOPE_PER_M:g} 1/m, and deg/s multiplies it by 57.3: the "
                    "gyro is in deg/s; convert wx, wy, wz to rad/s (x pi/180)", path, "wz")
            _check_wheel_sides(t_w[inside][keep], dv, wz, wheels_path, wheel_columns)
    lim = VEHICLE_LIMITS.get(vehicle)
    p99 = float(np.percentile(np.abs(gyro[2][ok]), 99)) if ok.any() else 0.0
    if spread > MAX_GYRO_SPREAD_RAD_S or (lim is not None and p99 > 2 * lim.max_yaw_rate_rad_s):
        found.append(f"{path}: rule gyro_units: gyro spread {spread:.2f} rad/s (median axis "
                     f"std; real runs <= 0.18), 99th-percentile |wz| {p99:.2f} rad/s: the gyro "
                     "is probably in deg/s; assumed rad/s as the format requires")


def _lag1(x: np.ndarray) -> float:
    """Lag-1 autocorrelation of ``x`` (0 for a constant ``x``)."""
    x0 = x - x.mean()
    d = float(x0 @ x0)
    return float(x0[1:] @ x0[:-1]) / d if d > 0 else 0.0


def _correlation(a: np.ndarray, b: np.ndarray) -> float:
    """Pearson correlation of ``a`` and ``b`` (0 where either is constant)."""
    a0, b0 = a - a.mean(), b - b.mean()
    d = math.sqrt(float(a0 @ a0) * float(b0 @ b0))
    return float(a0 @ b0) / d if d > 0 else 0.0


def wheel_sides_evidence(t_s: np.ndarray, speed_difference_m_s: np.ndarray,
                         yaw_rate_rad_s: np.ndarray) -> tuple[float, float, int]:
    """How strongly the yaw rate falls as the right wheels outrun the left (rule
    ``wheel_sides``, module docstring): the correlation of block means and the Fisher z of
    the correlation of their block-to-block changes.

    Parameters
    ----------
    t_s : ndarray, shape (n,)
        Wheel sample times, s, increasing.
    speed_difference_m_s : ndarray, shape (n,)
        ``v_R - v_L`` at those times, m/s, finite.
    yaw_rate_rad_s : ndarray, shape (n,)
        Gyro yaw rate at those times (interpolated), rad/s, finite.

    Returns
    -------
    corr : float
        Correlation of the :data:`WHEEL_SIDES_BLOCK_S` block means (0 with fewer than 2).
    z : float
        ``atanh(r) sqrt(m_eff - 3)`` of the correlation ``r`` of the block means' changes,
        ``m_eff = m / max(1, 1 + 2 r_a r_b)`` (Bartlett 1935: ``m`` changes with lag-1
        autocorrelations ``r_a``, ``r_b``); 0 where ``m_eff <= 3``.
    n_blocks : int
        Number of blocks holding a sample.
    """
    t = np.asarray(t_s, dtype=float)
    k = np.floor((t - t[0]) / WHEEL_SIDES_BLOCK_S).astype(np.int64)
    count = np.bincount(k)
    held = count > 0
    dv = np.bincount(k, speed_difference_m_s)[held] / count[held]
    wz = np.bincount(k, yaw_rate_rad_s)[held] / count[held]
    if dv.size < 2:
        return 0.0, 0.0, int(dv.size)
    corr = _correlation(dv, wz)
    a, b = np.diff(dv), np.diff(wz)
    m_eff = a.size / max(1.0, 1.0 + 2.0 * _lag1(a) * _lag1(b)) if a.size > 1 else 0.0
    r = min(max(_correlation(a, b), -1.0 + 1e-15), 1.0 - 1e-15)
    z = math.atanh(r) * math.sqrt(m_eff - 3.0) if m_eff > 3.0 else 0.0
    return corr, z, int(dv.size)


def _check_wheel_sides(t_w: np.ndarray, dv: np.ndarray, wz: np.ndarray, path,
                       columns: Sequence[str]) -> None:
    """Rule ``wheel_sides``: UnitError for left and right wheel columns swapped
    (``columns``: the file's columns of vel_l, vel_r, cur_l, cur_r, for the message)."""
    corr, z, n_blocks = wheel_sides_evidence(t_w, dv, wz)
    if n_blocks >= WHEEL_SIDES_MIN_BLOCKS and corr <= -0.5 and z <= WHEEL_SIDES_Z:
        vel_l, vel_r, cur_l, cur_r = columns
        raise UnitError(
            f"rule wheel_sides: the yaw rate falls as the right wheels run faster than the "
            f"left (correlation {corr:.2f} of {n_blocks} {WHEEL_SIDES_BLOCK_S:g} s means of "
            f"wz and {vel_r} - {vel_l}, z {z:.1f} of their changes): the left and right "
            f"wheel columns are swapped; the format's frame turns left (wz > 0) when the "
            f"right side runs faster: exchange {vel_l} with {vel_r} and {cur_l} with "
            f"{cur_r}", path, vel_l)


def wheel_speed_in_kmh(p99_speed: float, limits: VehicleLimits) -> bool:
    """Whether a 99th-percentile wheel speed says the wheel speeds are in km/h (rule
    ``wheel_speed_units``, its certain case): more than twice the vehicle's top speed.

    Parameters
    ----------
    p99_speed : float
        99th percentile of ``|vel_l|`` and ``|vel_r|`` together, in the stream's units
        (supposedly m/s).
    limits : VehicleLimits
        The vehicle's datasheet bounds (:data:`VEHICLE_LIMITS`).

    Returns
    -------
    bool
        True when ``p99_speed > 2 * limits.top_speed_m_s`` (km/h is 3.6 x m/s).
    """
    return p99_speed > 2.0 * limits.top_speed_m_s


def _check_wheel_speed(wheels, imu, lim: VehicleLimits, path, found,
                       speed_columns: Sequence[str] = ("vel_l", "vel_r")) -> None:
    speed = np.abs(np.r_[wheels["vel_l"].to_numpy(dtype=float),
                         wheels["vel_r"].to_numpy(dtype=float)])
    # (a non-finite sample is the non-finite rule's: an inf made the percentile inf, km/h,
    # and a NaN made it NaN, which passed speeds in km/h)
    speed = speed[np.isfinite(speed)]
    if not speed.size:
        return
    p99 = float(np.percentile(speed, 99))
    if wheel_speed_in_kmh(p99, lim):
        raise UnitError(
            f"rule wheel_speed_units: 99th-percentile wheel speed {p99:.3g} is more than twice "
            f"the top speed {lim.top_speed_m_s:g} m/s ({lim.source}); km/h is 3.6 x m/s: "
            f"convert {', '.join(speed_columns)} to m/s (/ 3.6; a wheel angular speed in "
            f"rad/s: x the wheel radius in m)", path, speed_columns[0])
    evidence = []
    if p99 > 1.2 * lim.top_speed_m_s:
        evidence.append(f"99th-percentile speed {p99:.3g} above 1.2 x top speed "
                        f"{lim.top_speed_m_s:g} m/s")
    slope = _speed_accel_slope(wheels, imu)
    if slope is not None and slope > 2.5:
        evidence.append(f"speed derivative / forward acceleration slope {slope:.2f} "
                        "(m/s gives about 1, km/h 3.6)")
    if evidence:
        found.append(f"{path}: rule wheel_speed_units: {'; '.join(evidence)}: wheel speeds "
                     "probably in km/h; assumed m/s as the format requires")


def _check_current(wheels, lim: VehicleLimits, path, found,
                   columns: Mapping[str, Mapping[str, str]] | None = None) -> None:
    """Rule ``current_range``: motor currents beyond the vehicle's bound, each channel's
    largest named with its time (a likely finding: the bound is assumed)."""
    for channel in ("cur_l", "cur_r"):
        if channel not in wheels.columns:
            continue
        # (a non-finite sample is the non-finite rule's: an inf is no current beyond it)
        current = np.abs(wheels[channel].to_numpy(dtype=float))
        current[~np.isfinite(current)] = 0.0
        beyond = current > lim.max_current_a
        if beyond.any():
            k = int(np.argmax(current))
            found.append(f"{path}: rule current_range: {int(beyond.sum())} sample(s) of "
                         f"{_channel_text(f'wheels.{channel}', columns)} beyond the vehicle's "
                         f"assumed {lim.max_current_a:g} A, the largest "
                         f"{wheels[channel].iloc[k]:g} A at t = {wheels[TIME].iloc[k]:.10g} s: "
                         "a current in another unit or scale?; assumed A as the format "
                         "requires")


def _speed_accel_slope(wheels, imu) -> float | None:
    """Slope of d(mean wheel speed)/dt on ax (1 s averages), when correlated >= 0.5."""
    if imu is None or len(imu) < 20 or len(wheels) < 10:
        return None
    t_i = imu[TIME].to_numpy()
    step = float(np.median(np.diff(t_i)))
    n = max(1, int(round(1.0 / step)))
    if t_i.size <= 2 * n:
        return None
    v = np.interp(t_i, wheels[TIME].to_numpy(),
                  0.5 * (wheels["vel_l"].to_numpy() + wheels["vel_r"].to_numpy()))
    ax = imu["ax"].to_numpy()
    dv = np.gradient(_moving_mean(v, n), t_i[n - 1:])
    ax = _moving_mean(ax, n)
    dv0, ax0 = dv - dv.mean(), ax - ax.mean()
    denom = math.sqrt(float(dv0 @ dv0) * float(ax0 @ ax0))
    if denom == 0 or float(dv0 @ ax0) / denom < 0.5:
        return None
    return float(dv0 @ ax0) / float(ax0 @ ax0)


def _moving_mean(x: np.ndarray, n: int) -> np.ndarray:
    """Means of the ``len(x) - n + 1`` full windows of ``n`` samples (O(len(x)))."""
    c = np.cumsum(np.r_[0.0, x])
    return (c[n:] - c[:-n]) / n


def stuck_window_flags(stuck: Mapping[str, list], t_start_s: np.ndarray,
                       t_end_s: np.ndarray) -> np.ndarray:
    """Flag the windows that hold a stuck stretch of a channel.

    Parameters
    ----------
    stuck : Mapping[str, list]
        ``Run.meta["stuck"]``: ``"<stream>.<channel>" -> [[t_start_s, t_end_s], ...]``.
    t_start_s, t_end_s : numpy.ndarray
        ``(n_windows,)`` window bounds on the run's clock, s: a window ``[t_start_s,
        t_end_s)`` holds a stretch ``[a, b]`` when ``a < t_end_s`` and ``b >= t_start_s``
        (the live service's rule, :meth:`terrain.serving.rules.StuckWatch.stuck_between`).

    Returns
    -------
    numpy.ndarray
        ``(n_windows,)`` strings: ``""`` or ``"stuck:<stream>.<channel>[,...]"``.
    """
    t0 = np.asarray(t_start_s, dtype=float)
    t1 = np.asarray(t_end_s, dtype=float)
    names = [[] for _ in range(t0.size)]
    for key, spans in stuck.items():
        hit = np.zeros(t0.size, dtype=bool)
        for a, b in spans:
            hit |= (t0 <= b) & (t1 > a)
        for i in np.flatnonzero(hit):
            names[i].append(key)
    return np.array([stuck_flag(n) for n in names], dtype=object)


def stuck_flag(keys: Sequence[str]) -> str:
    """The flag of a window holding stuck channels: ``"stuck:<stream>.<channel>[,...]"``.

    Parameters
    ----------
    keys : sequence of str
        ``<stream>.<channel>`` of the stuck channels, in order.

    Returns
    -------
    str
        ``""`` when ``keys`` is empty.
    """
    return "stuck:" + ",".join(keys) if keys else ""
