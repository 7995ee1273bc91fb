"""Windowing: cut aligned runs into fixed-length windows carrying their run id and label.

Windows are arrays ``(n_windows, n_channels, n_window_samples)``, the layout
``torch.nn.Conv1d`` expects. Window length and hop are in seconds. The thesis cuts 2 s
non-overlapping windows in steady motion (``001_59da564c4b2d6a48.txt`` ch. 8.1); the BorealTC
and Vulpi papers cut each run into 5 s partitions and slide 1.7 s windows by 0.1 s inside each
partition (``partition_s``).
"""

from __future__ import annotations

import copy
import datetime
import math
from dataclasses import dataclass, field
from types import MappingProxyType
from typing import Iterable, Mapping, Sequence

import numpy as np
import pandas as pd

from features.ekf_signals import EKF_CHANNELS, add_ekf_channels
from terrain.estimation.skid_steer import SkidSteerSettings
from terrain.errors import (ConfigError, DataFormatError, MissingColumnError, ShapeError,
                            TimestampError, config_flags, config_numbers, config_positive,
                            duplicated, first_items, holds_booleans, listed, real_arrays)
from terrain.io.align import DEFAULT_RATE_HZ, align_streams
from terrain.run import IMU_CHANNELS, TIME, WHEEL_CHANNELS, Run, times_out_of_order
from terrain.vehicles import HUSKY, HuskyParams, TrackedParams, body_rates, get_vehicle

#: Husky A200 track width B, m, the wheel-odometry yaw rate channel's default: the vehicle's
#: parameter :attr:`terrain.vehicles.HuskyParams.track_m` (source documented there).
HUSKY_TRACK_M = HUSKY.track_m

#: Derived wheel channels, each a function of the aligned frame (SI units):
#: ``vel_mean`` = (vel_l + vel_r)/2 [m/s], ``vel_diff`` = vel_r - vel_l [m/s],
#: ``cur_sum`` = cur_l + cur_r [A], ``cur_diff`` = cur_r - cur_l [A],
#: ``yaw_rate_wheels`` = (vel_r - vel_l)/B [rad/s] (ideal differential drive).
DERIVED_WHEEL_CHANNELS = ("vel_mean", "vel_diff", "cur_sum", "cur_diff", "yaw_rate_wheels")
#: Every raw (measured or derived-from-measured) channel.
ALL_CHANNELS = IMU_CHANNELS + WHEEL_CHANNELS + DERIVED_WHEEL_CHANNELS
#: Forward wheel-speed channels, m/s: the speed the robot was driven at (its level and its
#: profile), which an operator sets per recording session, not a response of the ground.
SPEED_CHANNELS = ("vel_l", "vel_r", "vel_mean")
#: Named signal sets. EKF-derived channels (:mod:`features.ekf_signals`): set ``ekf`` alone,
#: ``all+ekf`` with every raw channel; kept out of ``all`` so the raw default is unchanged.
#: ``all-no-speed``: ``all`` without :data:`SPEED_CHANNELS` (the IMU, the motor currents and
#: the wheels' turning channels ``vel_diff``, ``yaw_rate_wheels``; the per-speed current
#: features go with the speeds). On BorealTC the driven speed is a property of the recording
#: session (0.79 m/s straight runs are all ASPHALT but one ICE run), so a classifier that
#: sees it learns the sessions; without it, run-grouped accuracy on unseen runs rises
#: (docs/model_comparison.md, "Without the wheel speeds").
SIGNAL_SETS: Mapping[str, tuple[str, ...]] = MappingProxyType({
    "imu": IMU_CHANNELS,
    "wheels": WHEEL_CHANNELS + DERIVED_WHEEL_CHANNELS,
    "all": ALL_CHANNELS,
    "all-no-speed": tuple(c for c in ALL_CHANNELS if c not in SPEED_CHANNELS),
    "ekf": EKF_CHANNELS,
    "all+ekf": ALL_CHANNELS + EKF_CHANNELS,
})
KNOWN_CHANNELS = ALL_CHANNELS + EKF_CHANNELS


def resolve_signals(signals: str | Sequence[str]) -> tuple[str, ...]:
    """Channel names of a signal set (``imu``, ``wheels``, ``all``) or of a list of channels.

    A list may mix set names and channel names (``["imu", "cur_diff"]``).

    Parameters
    ----------
    signals : str or sequence of str
        A set name of :data:`SIGNAL_SETS` (``imu``, ``wheels``, ``all``, ``all-no-speed``,
        ``ekf``, ``all+ekf``), a channel name of :data:`KNOWN_CHANNELS`, or a sequence of both.

    Returns
    -------
    tuple of str
        Channel names in the order given, each set expanded, duplicates removed.

    Raises
    ------
    ConfigError
        Unknown set or channel name, or something that is not a name (the message lists the
        valid ones), or an empty selection.
    """
    try:
        items = [signals] if isinstance(signals, str) else list(signals)
    except TypeError:     # None, a number: list() cannot take them
        items = [signals]
    out: list[str] = []
    for item in items:
        if not isinstance(item, str):
            raise ConfigError(f"a signal is a set or channel name, got {item!r}; valid sets "
                              f"{list(SIGNAL_SETS)} or channels {list(KNOWN_CHANNELS)}")
        names = SIGNAL_SETS.get(item, (item,))
        for name in names:
            if name not in KNOWN_CHANNELS:
                raise ConfigError(f"unknown signal {name!r}; valid sets {list(SIGNAL_SETS)} "
                                  f"or channels {list(KNOWN_CHANNELS)}")
            if name not in out:
                out.append(name)
    if not out:
        raise ConfigError("empty signal selection")
    return tuple(out)


def derived_track_m(vehicle: str | None) -> float:
    """Track width B that the derived wheel channels of a run or model of a vehicle use, m.

    ``yaw_rate_wheels = (vel_r - vel_l) / B`` is the skid-steer kinematic yaw rate of that
    vehicle's own sides, so a run's windows (:func:`make_windows`) and a served model's
    live windows (:func:`terrain.serving.model.model_track_m`) take B from the vehicle.

    Parameters
    ----------
    vehicle : str or None
        A name of :data:`terrain.run.VEHICLE_NAMES` (any case; a run's ``vehicle``), or None
        when it is not known.

    Returns
    -------
    float
        The skid-steer vehicle's ``track_m``: ``husky`` 0.5708 m
        (:class:`terrain.vehicles.HuskyParams`), ``tracked`` 0.393 m
        (:class:`terrain.vehicles.TrackedParams`, seed 003 Table 2). :data:`HUSKY_TRACK_M`
        for None, and for the AgriMaRo, which has no left and right side: its ``wheels``
        stream holds the rim speeds of wheels 1 and 2 (steered, at d_1, d_2 = (-+0.5075, 0)
        m, :mod:`terrain.sim.simulate`), so its ``yaw_rate_wheels`` is their speed difference
        over the Husky's track, a feature the classifiers learn, not a yaw rate (what every
        vehicle got before the vehicle was read).

    Raises
    ------
    ConfigError
        An unknown vehicle name (:func:`terrain.vehicles.get_vehicle` lists the valid ones).
    """
    if vehicle is None:
        return HUSKY_TRACK_M
    params = get_vehicle(vehicle)
    if isinstance(params, (HuskyParams, TrackedParams)):
        return float(params.track_m)
    return HUSKY_TRACK_M


def runs_track_m(runs: Sequence[Run]) -> float:
    """The one track width a model trained on ``runs`` derives its live windows with, m.

    Parameters
    ----------
    runs : sequence of Run
        Training runs.

    Returns
    -------
    float
        :func:`derived_track_m` of their vehicle when they share one; the Husky's
        (:data:`HUSKY_TRACK_M`) when they come from several (each training window still used
        its own run's) or there is none.
    """
    vehicles = {str(r.vehicle).lower() for r in runs}
    return derived_track_m(vehicles.pop() if len(vehicles) == 1 else None)


def derived_wheel_arrays(vel_l: np.ndarray, vel_r: np.ndarray, cur_l: np.ndarray,
                         cur_r: np.ndarray, track_m: float = HUSKY_TRACK_M
                         ) -> dict[str, np.ndarray]:
    """The :data:`DERIVED_WHEEL_CHANNELS` of aligned wheel samples (NumPy only).

    Parameters
    ----------
    vel_l, vel_r : numpy.ndarray
        ``(n,)`` left and right wheel (track) speeds, m/s.
    cur_l, cur_r : numpy.ndarray
        ``(n,)`` left and right motor currents, A.
    track_m : float
        Track width B of the skid-steer vehicle, m.

    Returns
    -------
    dict of str to numpy.ndarray
        ``vel_mean = (vel_l + vel_r)/2`` and ``vel_diff = vel_r - vel_l`` (m/s),
        ``cur_sum`` and ``cur_diff = cur_r - cur_l`` (A), and the skid-steer kinematic
        (no-slip) yaw rate ``yaw_rate_wheels = vel_diff / track_m`` (rad/s;
        seeds/000_f24201ff985633bf.txt, Tazzari et al., eq. 2 with ``2d = track_m``), each
        ``(n,)``, in the order of :data:`DERIVED_WHEEL_CHANNELS`.

    Raises
    ------
    ConfigError
        ``track_m`` not a finite number > 0 (0 made the yaw rate NaN or infinite, a negative
        track turned it the other way, NaN made it NaN, all without a word).
    DataFormatError
        An input holding booleans (a mask was read as speeds of 0 and 1 m/s) or not
        converting to real numbers (text, None: NumPy's bare errors), naming it.
    ShapeError
        The four inputs not of one shape (NumPy broadcast a single sample to every row, or
        failed naming none of them).
    """
    # (the service's float track and rows skip the full checks: this runs per decision)
    if not (isinstance(track_m, float) and 0.0 < track_m < math.inf):
        config_positive("derived_wheel_arrays", track_m=track_m)
    try:
        checked = (vel_l.dtype.kind == vel_r.dtype.kind == cur_l.dtype.kind
                   == cur_r.dtype.kind == "f"
                   and vel_l.shape == vel_r.shape == cur_l.shape == cur_r.shape)
    except AttributeError:      # (lists, None)
        checked = False
    if not checked:
        vel_l, vel_r, cur_l, cur_r = inputs = real_arrays(
            "derived_wheel_arrays", vel_l=vel_l, vel_r=vel_r, cur_l=cur_l, cur_r=cur_r)
        if any(a.shape != vel_l.shape for a in inputs):
            raise ShapeError(f"derived_wheel_arrays: vel_l, vel_r, cur_l, cur_r must be "
                             f"arrays of one shape, got {[a.shape for a in inputs]}")
    # the skid-steer kinematics' one home (seed 000 eq. 2), ideal drive chi = 1
    vel_mean, yaw_rate = body_rates(vel_l, vel_r, track_m, 1.0)
    return {"vel_mean": vel_mean, "vel_diff": vel_r - vel_l, "cur_sum": cur_l + cur_r,
            "cur_diff": cur_r - cur_l, "yaw_rate_wheels": yaw_rate}


def _float_columns(frame: pd.DataFrame, columns: Sequence[str], owner: str) -> np.ndarray:
    """``frame[columns]`` as a float array ``(n_rows, len(columns))``, refusing a column of
    booleans (a mask was read as samples of 0 and 1) or one that does not convert to real
    numbers (pandas' bare ValueError or TypeError named no column) with a
    :class:`DataFormatError` naming it."""
    for c in columns:
        if holds_booleans(frame[c]):
            raise DataFormatError(f"{owner}: column {c!r} holds booleans, not samples", None, c)
    try:
        return frame[list(columns)].to_numpy(dtype=float)
    except (TypeError, ValueError):
        for c in columns:
            try:
                frame[c].to_numpy(dtype=float)
            except (TypeError, ValueError) as err:
                raise DataFormatError(f"{owner}: column {c!r} does not hold real numbers "
                                      f"({err})", None, c) from None
        raise


def add_derived_channels(frame: pd.DataFrame, track_m: float = HUSKY_TRACK_M) -> pd.DataFrame:
    """Add :data:`DERIVED_WHEEL_CHANNELS` to an aligned frame that has wheel channels.

    Parameters
    ----------
    frame : pandas.DataFrame
        Aligned frame with ``vel_l, vel_r, cur_l, cur_r`` (m/s, A).
    track_m : float
        Track width B of the skid-steer vehicle, m.

    Returns
    -------
    pandas.DataFrame
        A copy of ``frame`` with the channels of :func:`derived_wheel_arrays` added;
        ``frame`` itself, unchanged, when a wheel channel is missing.

    Raises
    ------
    ConfigError
        ``track_m`` not a finite number > 0 (:func:`derived_wheel_arrays`).
    DataFormatError
        A wheel channel of booleans (a mask read as speeds of 0 and 1 m/s) or of values
        that are not real numbers (pandas' bare error), naming the column.
    """
    if not set(WHEEL_CHANNELS) <= set(frame.columns):
        return frame
    wheels = _float_columns(frame, WHEEL_CHANNELS, "add_derived_channels")
    out = frame.copy()
    for name, values in derived_wheel_arrays(*wheels.T, track_m).items():
        out[name] = values
    return out


#: Speeds within this of a steady-motion limit count as on it, m/s: the float mean and spread
#: of equal samples carry rounding (100 samples of 0.1 m/s average to 0.09999999999999998
#: m/s, and their std is 3e-17 m/s, not 0), which dropped a window driven exactly at a limit;
#: the rounding of a window's mean stays below 1e-13 m/s (a million samples of 10 m/s), and
#: a window 1e-9 m/s beyond a limit is still beyond it.
STEADY_ROUNDING_M_S = 1e-12

#: Most samples one window may hold (a 10 000 s window at 100 Hz): longer windows are a
#: typo, not an experiment, and would allocate their whole grid before any run is cut.
MAX_WINDOW_SAMPLES = 1_000_000


@dataclass(frozen=True)
class WindowConfig:
    """How runs are cut into windows.

    The window, hop and partition lengths become whole samples of the aligned clock by
    rounding ``length_s * rate_hz`` to the nearest integer (:attr:`n_samples`,
    :attr:`hop_samples`, :attr:`partition_samples`); a length of exactly half a sample more
    goes to the even count, as Python's ``round`` does (1 s at 6.5 Hz is 6 samples, 3 s is
    20; a 0.5 s hop at 15 Hz is 8 samples).

    Parameters
    ----------
    window_s : float
        Window length, s (finite, > 0; at most :data:`MAX_WINDOW_SAMPLES` samples at
        ``rate_hz``, counted as :attr:`n_samples` rounds them).
    hop_s : float or None
        Step between window starts, s; ``None`` means ``window_s`` (no overlap).
    rate_hz : float
        Rate of the aligned clock, Hz (see :mod:`terrain.io.align`).
    partition_s : float or None
        If set, each run is first cut into non-overlapping partitions of this length and
        windows never cross a partition boundary (the papers' protocol uses 5 s).
    steady_only : bool
        Keep only windows in steady motion: |mean(vel_mean)| >= ``min_speed_m_s`` and
        std(vel_mean) <= ``max_speed_std_m_s``, both limits inclusive (a value within
        :data:`STEADY_ROUNDING_M_S` of a limit is on it; thesis ch. 8.1 uses
        steady-motion windows).
        It needs the wheel stream whatever the signals: runs without it are skipped, and a
        window whose wheel speeds are not all finite is dropped as a gap.
    min_speed_m_s, max_speed_std_m_s : float
        Steady-motion thresholds, m/s (finite, >= 0).

    Raises
    ------
    ConfigError
        A length or rate that is not a real number (text, a bool, a list) or not a finite
        positive number, ``partition_s`` shorter than ``window_s``, a window of fewer than
        4 or more than :data:`MAX_WINDOW_SAMPLES` samples, a hop that rounds to no sample
        (window starts and lengths are rounded to whole samples), a hop or partition that
        holds more samples than a float counts (``hop_s * rate_hz`` or ``partition_s *
        rate_hz`` infinite), or a steady-motion
        threshold that is not a finite number >= 0 (NaN made every window unsteady), or a
        ``steady_only`` that is not True or False (text, a number, None).
    """

    window_s: float = 2.0
    hop_s: float | None = None
    rate_hz: float = DEFAULT_RATE_HZ
    partition_s: float | None = None
    steady_only: bool = False
    min_speed_m_s: float = 0.1
    max_speed_std_m_s: float = 0.1

    def __post_init__(self) -> None:
        # text or a list raised Python's bare TypeError in the range checks, True passed as 1
        config_numbers("WindowConfig", optional=("hop_s", "partition_s"),
                       window_s=self.window_s, hop_s=self.hop_s, rate_hz=self.rate_hz,
                       partition_s=self.partition_s)
        if not (0 < self.window_s < math.inf and 0 < self.rate_hz < math.inf):
            raise ConfigError(f"window_s and rate_hz must be finite numbers > 0, got "
                              f"{self.window_s} s and {self.rate_hz} Hz")
        if self.hop_s is not None and not 0 < self.hop_s < math.inf:
            raise ConfigError(f"hop_s must be a finite number > 0 s, got {self.hop_s}")
        if self.partition_s is not None and not self.window_s <= self.partition_s < math.inf:
            raise ConfigError(f"partition_s must be finite and >= window_s, got "
                              f"{self.partition_s} s")
        for name, length_s in (("hop", self.hop_s), ("partition", self.partition_s)):
            if length_s is not None and not math.isfinite(length_s * self.rate_hz):
                # round() of the overflowed count raised a bare OverflowError (1e308 s at
                # 100 Hz: the hop's at construction, the partition's when cutting)
                raise ConfigError(f"{name}_s {length_s:g} s at {self.rate_hz:g} Hz is more "
                                  f"samples than a count can hold (give a shorter {name})")
        if self.hop_s is not None and round(self.hop_s * self.rate_hz) < 1:
            # it was cut at one sample while the run logged the hop asked for
            raise ConfigError(f"hop_s {self.hop_s:g} s is under one sample at {self.rate_hz:g} "
                              f"Hz ({1 / self.rate_hz:g} s): windows start on samples")
        samples = self.window_s * self.rate_hz     # (inf where the product overflows)
        if math.isinf(samples) or round(samples) > MAX_WINDOW_SAMPLES:
            # the cap is on the rounded count, the window's length (1 000 000.4 samples,
            # a window of 1 000 000, were refused as "holds 1e+06 samples")
            count = f"{round(samples):,}" if samples < 1e15 else f"{samples:.3g}"
            raise ConfigError(f"a window of {self.window_s:g} s at {self.rate_hz:g} Hz holds "
                              f"{count} samples; at most {MAX_WINDOW_SAMPLES:,} (a shorter "
                              "window or a lower rate)")
        if round(self.window_s * self.rate_hz) < 4:
            raise ConfigError(f"a window must hold at least 4 samples: a window of "
                              f"{self.window_s:g} s at {self.rate_hz:g} Hz holds "
                              f"{round(self.window_s * self.rate_hz)} (a longer window or a "
                              "higher rate)")
        config_positive("WindowConfig", allow_zero=True, min_speed_m_s=self.min_speed_m_s,
                        max_speed_std_m_s=self.max_speed_std_m_s)
        # read by truthiness, the text "no" of a config file turned the filter on
        config_flags("WindowConfig", steady_only=self.steady_only)

    @property
    def n_samples(self) -> int:
        """Samples per window: ``round(window_s * rate_hz)`` (a tie to the even count)."""
        return int(round(self.window_s * self.rate_hz))

    @property
    def hop_samples(self) -> int:
        """Samples between window starts: ``round(hop_s * rate_hz)`` (``window_s`` without
        a hop; a tie to the even count)."""
        return max(1, int(round((self.hop_s or self.window_s) * self.rate_hz)))

    @property
    def partition_samples(self) -> int | None:
        """Samples per partition: ``round(partition_s * rate_hz)`` (a tie to the even
        count; None without ``partition_s``)."""
        return None if self.partition_s is None else int(round(self.partition_s * self.rate_hz))


@dataclass
class WindowSet:
    """Windows of many runs, with their provenance.

    Attributes
    ----------
    X : numpy.ndarray
        ``(n_windows, n_channels, n_samples)``, SI units of each channel.
    channels : tuple of str
        Channel names, length ``n_channels``.
    run_ids : numpy.ndarray
        ``(n_windows,)`` run id of each window.
    groups : numpy.ndarray
        ``(n_windows,)`` split unit: the run id, or ``<run_id>#<k>`` for partition ``k``.
    labels : numpy.ndarray
        ``(n_windows,)`` terrain label (``None`` for unlabelled runs).
    t_start_s, t_end_s : numpy.ndarray
        ``(n_windows,)`` window bounds on the run's clock, s.
    rate_hz : float
        Sampling rate of the windows, Hz.
    counts : dict
        Book-keeping: windows kept, dropped for gaps or unsteady motion, window positions
        wholly inside a gap (``empty_gap``, see :func:`window_frame`), time after the last
        full partition (``partition_tail_s``, s) and after the last window of a run or
        partition (``window_tail_s``, s), time between windows cut at a hop longer than
        the window (``between_windows_s``, s), runs skipped for a missing stream and runs
        shorter than one window or partition (with their ids; ``reasons``: run id -> why),
        and ``per_run``: run id -> ``windows``, ``dropped_gap``, ``empty_gap``,
        ``dropped_unsteady``, ``partition_tail_s``, ``window_tail_s``,
        ``between_windows_s``, ``aligned_s``;
        ``streams``: the streams aligned (:func:`required_streams` of the channels, and
        ``wheels`` with ``steady_only``). A
        :meth:`subset` adds
        ``not_selected`` (in total and per run): windows cut but left out by the selection.
    """

    X: np.ndarray
    channels: tuple[str, ...]
    run_ids: np.ndarray
    groups: np.ndarray
    labels: np.ndarray
    t_start_s: np.ndarray
    t_end_s: np.ndarray
    rate_hz: float
    counts: dict = field(default_factory=dict)

    def __len__(self) -> int:
        return int(self.X.shape[0])

    def subset(self, mask: np.ndarray) -> "WindowSet":
        """Windows selected by a boolean mask or index array.

        Parameters
        ----------
        mask : numpy.ndarray
            ``(n_windows,)`` bool mask, or an integer index array, over the windows.

        Returns
        -------
        WindowSet
            The selected windows with the same ``channels`` and ``rate_hz`` and a copy of
            ``counts`` that states the subset: ``windows`` (in total and per run) counts the
            selected windows, and ``not_selected`` (in total and per run) the windows of
            this set that the selection leaves out (added to any count already there). The
            counts of what windowing dropped or skipped are kept as they are.

        Raises
        ------
        ShapeError
            ``mask`` not 1-D, a boolean mask of another length than the windows, an index
            outside the windows (``-n..n-1``), or neither booleans nor integers.
        """
        n, sel = len(self), np.asarray(mask)
        if sel.ndim != 1:       # (NumPy's bare IndexError named neither mask nor windows)
            raise ShapeError(f"WindowSet.subset: mask must be 1-D (a boolean mask or window "
                             f"indices), got shape {sel.shape}")
        if sel.size == 0:
            sel = sel.astype(int)
        if sel.dtype == bool and sel.size != n:
            raise ShapeError(f"WindowSet.subset: boolean mask of {sel.size} entries for {n} "
                             "windows")
        if sel.dtype != bool and sel.dtype.kind not in "iu":
            raise ShapeError(f"WindowSet.subset: mask must be booleans or window indices, got "
                             f"dtype {sel.dtype}")
        if sel.dtype != bool:
            outside = (sel < -n) | (sel >= n)
            if outside.any():
                raise ShapeError(f"WindowSet.subset: window index {sel[outside][0]} outside "
                                 f"0..{n - 1} (or -{n}..-1 from the end)")
        rows = np.arange(n)[sel]
        counts = copy.deepcopy(self.counts)
        if "windows" in counts:
            counts["windows"] = int(rows.size)
        counts["not_selected"] = (counts.get("not_selected", 0)
                                  + len(self) - np.unique(rows).size)
        for rid, entry in counts.get("per_run", {}).items():
            mine = self.run_ids == rid
            kept = np.unique(rows[mine[rows]]).size
            entry["not_selected"] = entry.get("not_selected", 0) + int(mine.sum()) - kept
            entry["windows"] = int(mine[rows].sum())
        return WindowSet(self.X[rows], self.channels, self.run_ids[rows], self.groups[rows],
                         self.labels[rows], self.t_start_s[rows], self.t_end_s[rows],
                         self.rate_hz, counts)


def _is_real(value) -> bool:
    """Whether Python's ``float`` reads ``value`` as a number (a list or a dict it does not)."""
    try:
        float(value)
    except (TypeError, ValueError):
        return False
    return True


def as_windows(X, channels: Sequence[str]) -> np.ndarray:
    """``X`` as float windows holding one row per channel, refused otherwise.

    The feature transformers read their channels by position, so a window array of another
    channel count is refused, and one of 0 windows is refused as scikit-learn refuses 0
    samples.

    Parameters
    ----------
    X : array-like
        ``(n_windows, n_channels, n_samples)`` windows.
    channels : sequence of str
        ``(n_channels,)`` channel names, in the order of ``X``'s second axis.

    Returns
    -------
    numpy.ndarray
        ``X`` as a float array; a missing item of an object array (None, ``pandas.NA``)
        is NaN, which the transformers refuse as non-finite.

    Raises
    ------
    ValueError
        ``X`` not of real numbers (booleans, text, complex, times, as the array's dtype
        or as items of an object array: a conversion to float made a mask samples of 0
        and 1, parsed text, dropped imaginary parts and read a datetime64 as its days
        since 1970; lists and other objects float() does not read), not of 3
        dimensions, of another number of channels than ``channels``, or of 0 windows.
    """
    X = np.asarray(X)
    if X.dtype.kind not in "iufO":     # (object: a pandas or mixed array, converted below)
        raise ValueError(f"X must hold real numbers (signal samples), got dtype {X.dtype}")
    if X.dtype.kind == "O":           # (astype(float) read True as 1.0 and parsed "1.5")
        # (a datetime64 item was read as its count of days or seconds since 1970)
        kinds = (bool, np.bool_, str, bytes, complex, np.complexfloating, np.datetime64,
                 np.timedelta64, datetime.date, datetime.timedelta)
        odd = next((v for v in X.flat if isinstance(v, kinds)), None)
        if odd is None:
            # a missing value (None, pandas' NA of a nullable column) is NaN, which the
            # transformers refuse naming channel and window (pd.NA was a bare TypeError)
            X = np.where(pd.isna(X), np.nan, X)
            odd = next((v for v in X.flat if not _is_real(v)), None)
        if odd is not None:
            raise ValueError(f"X must hold real numbers (signal samples), got an object array "
                             f"holding {odd!r} ({type(odd).__name__})")
    X = X.astype(float, copy=False)
    if X.ndim != 3 or X.shape[1] != len(channels):
        raise ValueError(f"expected X of shape (n_windows, {len(channels)}, n_samples), "
                         f"got {X.shape}")
    if X.shape[0] == 0:
        raise ValueError(f"found 0 windows (X of shape {X.shape}) while a minimum of 1 is "
                         "required")
    return X


def refuse_changed_layout(transformer) -> None:
    """Refuse to transform after a setting was changed since ``fit``.

    A feature transformer checks its settings and fixes its output names at ``fit``; a
    ``set_params`` after ``fit`` changed the columns ``transform`` builds but not the names
    (``stats=("mean",)``: 22 columns under 36 names), or brought in a setting fit would
    refuse (a speed floor of 0: infinite features). Transformers fitted before ``layout_``
    existed are not checked.

    Parameters
    ----------
    transformer : object
        A fitted transformer with ``_layout()`` (``(setting, value)`` pairs) and the
        ``layout_`` that ``fit`` stored.

    Raises
    ------
    sklearn.exceptions.NotFittedError
        A setting differs from its value at ``fit``; the message names it.
    """
    fitted = getattr(transformer, "layout_", None)
    if fitted is None:
        return
    now = transformer._layout()
    if now != fitted:
        from sklearn.exceptions import NotFittedError

        changed = [name for (name, a), (_, b) in zip(now, fitted) if a != b]
        raise NotFittedError(f"{type(transformer).__name__}: settings {listed(changed)} "
                             "changed since fit, which checked them and fixed the output "
                             "columns from them; fit again")


def refuse_non_finite(X: np.ndarray, channels: Sequence[str],
                      error: type[ValueError] = ValueError, owner: str = "") -> None:
    """Refuse windows holding NaN or inf, naming the channels and the first windows.

    Parameters
    ----------
    X : numpy.ndarray
        ``(n_windows, n_channels, n_samples)`` windows.
    channels : sequence of str
        ``(n_channels,)`` channel names, in the order of ``X``'s second axis.
    error : type
        The ValueError (sub)class raised (the transformers raise ValueError, as scikit-learn
        does; the slip features :class:`~terrain.errors.NonFiniteInputError`).
    owner : str
        Put first in the message (``"<owner>: "``) where not empty.

    Raises
    ------
    ValueError
        ``error``: a value of ``X`` is NaN or infinite; the message names each channel
        holding one and the first windows (their index in ``X``).
    """
    bad = ~np.isfinite(X)
    if not bad.any():
        return
    per = bad.any(axis=2)             # (n_windows, n_channels)
    parts = [f"{name!r} in {first_items(np.flatnonzero(per[:, j]), word='window')}"
             for j, name in enumerate(channels) if per[:, j].any()]
    n = int(bad.sum())
    raise error(f"{owner + ': ' if owner else ''}X contains NaN or inf ({n} "
                f"value{'s' if n > 1 else ''}): {'; '.join(parts)}")


def required_streams(channels: Iterable[str]) -> tuple[str, ...]:
    """Streams a channel selection needs (``imu`` and/or ``wheels``).

    Parameters
    ----------
    channels : iterable of str
        Channel names (IMU, wheel, derived wheel or EKF channels).

    Returns
    -------
    tuple of str
        ``("imu",)``, ``("wheels",)`` or ``("imu", "wheels")``: ``imu`` when an IMU or EKF
        channel is selected, ``wheels`` when any channel is not an IMU channel (EKF channels
        need both streams).

    Raises
    ------
    ConfigError
        ``channels`` one text (its letters were read as channels: ``"wz"`` needed the
        wheels) or not iterable, or holding a name that is not one of
        :data:`KNOWN_CHANNELS` (a misspelt IMU channel counted as a wheel channel), naming
        the first.
    """
    if isinstance(channels, str) or not isinstance(channels, Iterable):
        raise ConfigError(f"required_streams: channels must be a sequence of channel names, "
                          f"got {channels!r}")
    channels = list(channels)     # (an iterator is read once)
    unknown = [c for c in channels if c not in KNOWN_CHANNELS]
    if unknown:
        raise ConfigError(f"required_streams: unknown channel {unknown[0]!r}; valid "
                          f"channels {list(KNOWN_CHANNELS)}")
    chans = set(channels)
    need = []
    if chans & (set(IMU_CHANNELS) | set(EKF_CHANNELS)):
        need.append("imu")
    if chans - set(IMU_CHANNELS):
        need.append("wheels")
    return tuple(need)


def check_uniform_clock(t_s: np.ndarray, rate_hz: float, where: str | None = None,
                        rows: np.ndarray | None = None) -> None:
    """Refuse times that are not on a uniform clock at ``rate_hz``: windows are cut by row.

    The samples' median step must be within 1 % of the model's period (the rate is compared,
    as the message gives it: a step check refused 49.502 Hz, 0.996 % slow, and took 50.503
    Hz), and no step may be longer than 1.5 periods (a missing row would put both sides of a
    time hole in one window: :func:`terrain.io.align.align_streams` keeps the clock uniform
    and marks a gap by rows of NaN).

    Parameters
    ----------
    t_s : ndarray, shape (n,)
        Sample times, s, finite and strictly increasing.
    rate_hz : float
        The model's (the window configuration's) sample rate, Hz.
    where : str, optional
        What holds the times, for the message (e.g. ``"model input, run 3"``).
    rows : ndarray, shape (n,), optional
        Row of each sample as the user gave it (a request's row), named by the error;
        default the position in ``t_s``.

    Raises
    ------
    ConfigError
        ``rate_hz`` not a finite number > 0 (0 Hz was a "samples at 50 Hz, expects 0 Hz"
        refusal of the data, ``True`` a 1 Hz clock).
    ShapeError
        ``t_s`` not 1-D (a 2-D array was read as its flattened steps), or ``rows`` not of
        the length of ``t_s``.
    DataFormatError
        ``t_s`` does not convert to real numbers, or the median step's rate is more than
        1 % off ``rate_hz``, naming the column.
    TimestampError
        A time that is not finite or not after the previous one (a NaN time or a repeated
        one passed as on the clock, times running backwards were "samples at -50 Hz"), or
        a step longer than 1.5 periods, naming the column and the first offending row.
    """
    config_positive("check_uniform_clock", rate_hz=rate_hz)
    t_s, = real_arrays("check_uniform_clock", t_s=t_s)
    if t_s.ndim != 1 or (rows is not None and np.shape(rows) != t_s.shape):
        raise ShapeError(f"check_uniform_clock: t_s must be 1-D and rows (when given) of "
                         f"its length, got shapes {t_s.shape} and "
                         f"{None if rows is None else np.shape(rows)}")
    bad = times_out_of_order(t_s)
    if bad.size:
        row = int(bad[0])
        why = (f"a non-finite time {float(t_s[row])!r}" if not np.isfinite(t_s[row]) else
               f"time {float(t_s[row])!r} not after the previous row's "
               f"{float(t_s[row - 1])!r}")
        raise TimestampError(f"check_uniform_clock: {why}; aligned samples are on a uniform, "
                             "strictly increasing clock (align with align_streams)", where,
                             TIME, row if rows is None else int(rows[row]))
    dt = np.diff(t_s)
    if dt.size and abs(1.0 / (np.median(dt) * rate_hz) - 1.0) > 0.01:
        raise DataFormatError(f"samples at {1 / np.median(dt):.3f} Hz; the model expects "
                              f"{rate_hz} Hz (align with align_streams)", where, TIME)
    hole = dt * rate_hz > 1.5
    if hole.any():
        row = int(np.flatnonzero(hole)[0]) + 1
        raise TimestampError(f"a step of {dt[row - 1]:.6g} s, {hole.sum()} step(s) longer "
                             f"than 1.5 sample periods; aligned samples are on a uniform "
                             f"{rate_hz:g} Hz clock, a gap being rows of NaN "
                             f"(align with align_streams)", where, TIME,
                             row if rows is None else int(rows[row]))


def window_frame(frame: pd.DataFrame, channels: Sequence[str], config: WindowConfig
                 ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, dict]:
    """Cut one aligned frame into windows.

    Parameters
    ----------
    frame : pandas.DataFrame
        Aligned frame (``t_s`` + channels) at ``config.rate_hz``.
    channels : sequence of str
        Channels to keep, in order.
    config : WindowConfig

    Returns
    -------
    X : numpy.ndarray
        ``(n_windows, n_channels, n_samples)``.
    t_start_s, t_end_s : numpy.ndarray
        ``(n_windows,)``; ``t_end_s`` is the time of the last sample plus one period.
    partition : numpy.ndarray
        ``(n_windows,)`` partition index (0 when ``partition_s`` is None).
    counts : dict
        ``dropped_gap`` (windows of data holding a non-finite value: a timestamp gap; with
        ``steady_only``, also a non-finite wheel speed outside the selected channels),
        ``empty_gap`` (window positions without a single finite value, wholly inside a gap
        of every channel: not windows of data, so not counted as dropped; not returned
        either), ``dropped_unsteady``, ``partition_tail_s``: the time after the last
        full partition (s; the whole frame when it holds none), which no window is cut
        from (0 when ``partition_s`` is None), and ``window_tail_s``: the time after the
        last window of the frame, or of each partition, which no window covers (s; the
        whole frame when it is shorter than one window and ``partition_s`` is None), and
        ``between_windows_s``: the time between consecutive windows when the hop is longer
        than the window, which no window covers either (s; 0 when ``hop_s <= window_s``).

    Raises
    ------
    ConfigError
        ``channels`` empty or one string (each of its letters was read as a channel), or
        ``config.steady_only`` and the frame has no ``vel_l`` or ``vel_r`` column.
    MissingColumnError
        The frame has no ``t_s`` column or lacks one of ``channels`` (pandas' bare KeyError
        named the whole selection), naming the first missing one.
    TimestampError
        The frame's ``t_s`` is not finite and strictly increasing, or steps by more than 1.5
        periods of ``config.rate_hz`` (:func:`check_uniform_clock`), naming the column and
        the first offending row.
    DataFormatError
        The frame's median step is not ``config.rate_hz``'s period within 1 %
        (:func:`check_uniform_clock`), or a selected channel (with ``steady_only``, a wheel
        speed) holds booleans (a mask was cut into windows of 0 and 1) or values that are
        not real numbers (pandas' bare error), naming the column.
    """
    if isinstance(channels, str) or not hasattr(channels, "__len__") or not len(channels):
        # no channel: every window was returned empty and counted as a gap too
        raise ConfigError(f"window_frame: channels must be a sequence of one or more channel "
                          f"names, got {channels!r}")
    absent = [c for c in (TIME, *channels) if c not in frame.columns]
    if absent:
        raise MissingColumnError(f"window_frame: the aligned frame has no column(s) "
                                 f"{listed(absent)}; it has {listed(list(frame.columns))}",
                                 column=absent[0])
    missing = sorted({"vel_l", "vel_r"} - set(frame.columns)) if config.steady_only else []
    if missing:     # (checked before a frame shorter than one window returns)
        raise ConfigError(f"steady_only needs the wheel speeds; the frame has no "
                          f"{missing} column(s)")
    values = _float_columns(frame, channels, "window_frame")
    t = frame[TIME].to_numpy()
    # windows are cut by position: a frame out of time order gave windows whose start times
    # went back or repeated (or were NaN), without a word
    out_of_order = times_out_of_order(t)
    if out_of_order.size:
        row = int(out_of_order[0])
        raise TimestampError(f"window_frame: the aligned frame's times must increase "
                             f"strictly, got {float(t[row])!r} at row {row}", None, TIME, row)
    check_uniform_clock(t, config.rate_hz)     # windows are cut by row
    total = len(t)
    # a hop past the frame cuts its first window only, as one of the frame's length does
    # (a count past 64 bits, 1e17 s at 100 Hz, made the starts floats: NumPy's IndexError)
    n, hop = config.n_samples, min(config.hop_samples, max(total, 1))
    tail = 0
    if config.partition_s is None:
        bounds = [(0, total)]
    else:
        p = config.partition_samples
        bounds = [(s, s + p) for s in range(0, total - p + 1, p)]
        tail = total - p * len(bounds)
    starts, parts = [], []
    window_tail = 0     # samples after the last window of each partition (or of the frame)
    between = 0         # samples skipped between windows by a hop longer than the window
    for k, (a, b) in enumerate(bounds):
        s = np.arange(a, b - n + 1, hop)
        starts.append(s)
        parts.append(np.full(s.size, k))
        window_tail += b - (int(s[-1]) + n if s.size else a)
        between += max(hop - n, 0) * max(s.size - 1, 0)
    start = np.concatenate(starts) if starts else np.zeros(0, int)
    part = np.concatenate(parts) if parts else np.zeros(0, int)
    counts = {"dropped_gap": 0, "empty_gap": 0, "dropped_unsteady": 0,
              "partition_tail_s": tail / config.rate_hz,
              "window_tail_s": window_tail / config.rate_hz,
              "between_windows_s": between / config.rate_hz}
    if start.size == 0:
        return (np.zeros((0, len(channels), n)), np.zeros(0), np.zeros(0), part, counts)
    idx = start[:, None] + np.arange(n)[None, :]
    X = values[idx].transpose(0, 2, 1)  # (n_windows, n_channels, n_samples)
    finite = np.isfinite(X)
    keep = finite.all(axis=(1, 2))
    empty = ~finite.any(axis=(1, 2))
    counts["dropped_gap"] = int((~keep & ~empty).sum())
    counts["empty_gap"] = int(empty.sum())
    if config.steady_only:
        speeds = _float_columns(frame, ("vel_l", "vel_r"), "window_frame")
        v = 0.5 * (speeds[:, 0] + speeds[:, 1])[idx]
        # a wheel gap inside windows of finite selected channels (an IMU-only selection)
        # is a gap, not unsteady motion
        v_gap = keep & ~np.isfinite(v).all(axis=1)
        counts["dropped_gap"] += int(v_gap.sum())
        keep &= ~v_gap
        steady = np.zeros(len(keep), dtype=bool)
        # (a window driven exactly at a limit is on it despite the float rounding)
        floor = config.min_speed_m_s - STEADY_ROUNDING_M_S
        spread = config.max_speed_std_m_s + STEADY_ROUNDING_M_S
        steady[keep] = ((np.abs(v[keep].mean(axis=1)) >= floor)
                        & (v[keep].std(axis=1) <= spread))
        counts["dropped_unsteady"] = int((keep & ~steady).sum())
        keep &= steady
    t0 = t[start]
    return X[keep], t0[keep], t0[keep] + n / config.rate_hz, part[keep], counts


def make_windows(runs: Sequence[Run], signals: str | Sequence[str] = "all",
                 config: WindowConfig = WindowConfig(), progress: bool = False) -> WindowSet:
    """Align every run and cut it into windows.

    Runs lacking a stream that the signal selection needs (e.g. the BorealTC runs without
    an IMU file when ``signals`` includes IMU channels; with ``config.steady_only``, runs
    without the wheel stream, whatever the signals) are skipped and listed in
    ``counts["skipped_runs"]``; runs shorter than one window, or with ``partition_s``
    shorter than one partition, are listed in ``counts["too_short_runs"]``, the reason of
    each in ``counts["reasons"]``; with ``partition_s``, the time after the last full
    partition of each run, which no window is cut from, is counted in
    ``counts["partition_tail_s"]``, and with or without partitions the time after the last
    window of each run (or partition) in ``counts["window_tail_s"]``, and the time between
    windows cut at a hop longer than the window in ``counts["between_windows_s"]`` (s, in
    total and per run). Nothing is dropped silently. The derived wheel channels and the EKF
    channels use each run's own vehicle's track width (:func:`derived_track_m` of ``run.vehicle``).

    Parameters
    ----------
    runs : sequence of Run
        The runs, each read once (an iterator of runs is windowed as the same runs in a
        list).
    signals : str or sequence of str
        See :func:`resolve_signals`.
    config : WindowConfig
    progress : bool
        Show a progress bar (tqdm) over runs.

    Returns
    -------
    WindowSet

    Raises
    ------
    ConfigError
        An unknown signal (:func:`resolve_signals`), or two runs sharing one run id (their
        windows would be grouped, split and counted as one run's).
    MissingColumnError
        A run's stream lacks a channel the signals read (a derived wheel channel reads all
        of :data:`~terrain.run.WHEEL_CHANNELS`, the EKF channels ``wz``, ``vel_l`` and
        ``vel_r``, and ``config.steady_only`` ``vel_l`` and ``vel_r``), naming the run, the
        stream and the columns.
    """
    channels = resolve_signals(signals)
    runs = list(runs)   # (an iterator was read to its end by the id check: no run windowed)
    shared = duplicated(run.run_id for run in runs)
    if shared:
        raise ConfigError(f"runs share run id(s) {listed(shared)}: windows are grouped, "
                          "split and counted by run id, so each run needs its own")
    need = required_streams(channels)
    Xs, rids, groups, labels, t0s, t1s = [], [], [], [], [], []
    counts = {"windows": 0, "dropped_gap": 0, "empty_gap": 0, "dropped_unsteady": 0,
              "partition_tail_s": 0.0, "window_tail_s": 0.0, "between_windows_s": 0.0,
              "skipped_runs": [],
              "too_short_runs": [], "reasons": {}, "per_run": {}}
    iterator = runs
    if progress:
        from tqdm.auto import tqdm
        iterator = tqdm(runs, desc="windowing runs", unit="run")
    # steady-motion selection needs the wheel speeds even for IMU-only signal sets
    streams = tuple(dict.fromkeys(need + (("wheels",) if config.steady_only else ())))
    # the streams aligned: with both, each is cut to the other's span (the input report)
    counts["streams"] = list(streams)
    # the raw channels the selection reads (the derived ones are made from all four wheel
    # channels, the EKF ones from wz, vel_l and vel_r, the steady-motion filter from
    # vel_l and vel_r): a stream lacking one ended in a bare KeyError of the windowing
    derived = bool(set(channels) & set(DERIVED_WHEEL_CHANNELS))
    ekf = bool(set(channels) & set(EKF_CHANNELS))
    speeds = ("vel_l", "vel_r") if ekf or config.steady_only else ()
    columns = {"imu": [c for c in IMU_CHANNELS if c in channels or (ekf and c == "wz")],
               "wheels": [c for c in WHEEL_CHANNELS if derived or c in channels or c in speeds]}
    for run in iterator:
        if any(s not in run.streams for s in streams):
            counts["skipped_runs"].append(run.run_id)
            if "wheels" not in need and "wheels" not in run.streams:
                counts["reasons"][run.run_id] = "no wheels stream, which steady_only needs"
            continue
        for s in streams:
            run.require_columns(s, columns[s])
        # the run's own track width: the wheel yaw rate and the EKF are per vehicle
        track_m = derived_track_m(run.vehicle)
        frame = add_derived_channels(align_streams(run, streams, config.rate_hz), track_m)
        if set(channels) & set(EKF_CHANNELS):
            frame = add_ekf_channels(frame, wheel_rate_hz=run.rate_hz("wheels"),
                                     settings=SkidSteerSettings(track_m=track_m))
        X, t0, t1, part, c = window_frame(frame, channels, config)
        counts["dropped_gap"] += c["dropped_gap"]
        counts["empty_gap"] += c["empty_gap"]
        counts["dropped_unsteady"] += c["dropped_unsteady"]
        counts["partition_tail_s"] += c["partition_tail_s"]
        counts["window_tail_s"] += c["window_tail_s"]
        counts["between_windows_s"] += c["between_windows_s"]
        counts["per_run"][run.run_id] = {"windows": len(X), **c, "aligned_s": len(frame)
                                         / config.rate_hz}
        if len(frame) < config.n_samples:
            counts["too_short_runs"].append(run.run_id)
            counts["reasons"][run.run_id] = f"shorter than one {config.window_s:g} s window"
        elif config.partition_s is not None and len(frame) < config.partition_samples:
            counts["too_short_runs"].append(run.run_id)
            counts["reasons"][run.run_id] = (f"shorter than one {config.partition_s:g} s "
                                             "partition")
        Xs.append(X)
        t0s.append(t0)
        t1s.append(t1)
        rids.append(np.full(len(X), run.run_id, dtype=object))
        labels.append(np.full(len(X), run.terrain, dtype=object))
        if config.partition_s is None:
            groups.append(np.full(len(X), run.run_id, dtype=object))
        else:
            groups.append(np.array([f"{run.run_id}#{k}" for k in part], dtype=object))
    n = config.n_samples
    cat = (lambda xs, empty: np.concatenate(xs) if xs else empty)
    ws = WindowSet(
        X=cat(Xs, np.zeros((0, len(channels), n))), channels=channels,
        run_ids=cat(rids, np.zeros(0, object)), groups=cat(groups, np.zeros(0, object)),
        labels=cat(labels, np.zeros(0, object)), t_start_s=cat(t0s, np.zeros(0)),
        t_end_s=cat(t1s, np.zeros(0)), rate_hz=config.rate_hz, counts=counts)
    counts["windows"] = len(ws)
    return ws
