"""A measured run fed to the closed loop's online estimators, call by call.

:func:`terrain.sim.closed_loop.replay_observations` replays a *simulated* run through the
loop's sensor model; :func:`measured_observations` does the same for a *recorded* skid-steer
run: its logged IMU, wheel-speed and motor-current samples, in time order, cut into the
:class:`~terrain.sim.closed_loop.Observation` s a controller at ``control_rate_hz`` would
have received. It is what the online estimators (:mod:`terrain.control.estimators`) see on
a real robot: the accelerometer with gravity and the terrain's vibration, the wheel stream
at its own rate (about 6.5 Hz on BorealTC's Husky), no camera.
"""

from __future__ import annotations

from typing import Iterator

import numpy as np
import pandas as pd

from terrain.errors import (ClockError, ConfigError, DataFormatError, MissingColumnError,
                            NonNumericError, config_numbers)
from terrain.run import TIME, Run, clock_slack, times_out_of_order
from terrain.sim.closed_loop import Observation


class MeasuredObservations:
    """The observations of :func:`measured_observations` (an iterator, once through), and
    the logged samples that no call receives, counted per stream.

    Parameters
    ----------
    calls : iterator of Observation
        The observations, in call order.
    dropped_before_start : dict
        Stream (``imu``, ``wheels``) -> samples before the first call: the earlier stream's
        samples before the later one starts.
    dropped_after_end : dict
        Stream -> samples after the last call: the longer stream's samples after the
        shorter one ends, and those of both after the last call time of the grid.
    """

    def __init__(self, calls: Iterator[Observation], dropped_before_start: dict[str, int],
                 dropped_after_end: dict[str, int]) -> None:
        self._calls = calls
        self.dropped_before_start = dropped_before_start
        self.dropped_after_end = dropped_after_end

    def __iter__(self) -> "MeasuredObservations":
        return self

    def __next__(self) -> Observation:
        return next(self._calls)


def measured_observations(run: Run, wheel_radius_m: float, control_rate_hz: float = 50.0
                          ) -> MeasuredObservations:
    """Observations of a recorded skid-steer run, as a controller at ``control_rate_hz``
    would have received them.

    Calls are at ``t0, t0 + 1/rate, ...`` from the later of the two streams' first samples
    (``t0``) to the earlier of their last (a call on it, within the clock's rounding,
    :func:`terrain.run.clock_slack`, is made on any clock's origin); each call carries the
    samples after the previous call up to and including its own time (the first call also
    those at ``t0``); a sample stamped after a call's time by the clock's rounding alone
    (2.4e-7 s on an epoch clock, a sample logged at the call's time) goes to the next call:
    no call receives a sample stamped after it, whose age would be negative. Wheel speeds
    become encoder rates ``vel / r``; currents are reported as magnitudes, as the
    loop's drives report them. Both IMU views carry the logged samples: ``imu_full`` all six
    channels, ``imu`` its ``ax, ay, wz``, with the gravity and the vibration that the
    simulated loop's ``imu`` leaves out (a real IMU has no clean view). The low-level
    command is not logged and is given as zeros. The samples that no call receives (before
    ``t0``, after the last call) are counted per stream in the result's
    ``dropped_before_start`` and ``dropped_after_end``.

    Parameters
    ----------
    run : Run
        A run with an ``imu`` stream (``t_s, wx, wy, wz, ax, ay, az``, rad/s and m/s^2) and
        a ``wheels`` stream (``t_s, vel_l, vel_r, cur_l, cur_r``, m/s and A), e.g. a BorealTC
        run of :func:`terrain.io.shipped.read_shipped`.
    wheel_radius_m : float
        Wheel radius, m (> 0): rim speed to encoder rate.
    control_rate_hz : float
        Call rate, Hz (> 0).

    Returns
    -------
    MeasuredObservations
        Iterator of :class:`~terrain.sim.closed_loop.Observation` s, the samples since the
        previous call (``steer`` and ``cam`` empty); with the counts of the samples left
        out.

    Raises
    ------
    ConfigError
        A radius or rate that is not a real number (named), or not finite and > 0.
    MissingColumnError
        A stream or channel missing (named, with the run).
    NonNumericError
        A channel holding a value that is not a real number (text, a boolean), named with
        the run, the column and the first such row.
    DataFormatError
        A stream without samples, or whose times are not finite and non-decreasing (named,
        with the run, the column ``t_s`` and the first such row: a sample out of order
        would be lost to the cuts).
    ClockError
        The two streams' time spans do not overlap (both spans given): no call would
        receive both.
    """
    config_numbers("measured_observations", wheel_radius_m=wheel_radius_m,
                   control_rate_hz=control_rate_hz)
    if not (0 < wheel_radius_m < np.inf and 0 < control_rate_hz < np.inf):
        raise ConfigError(f"wheel_radius_m and control_rate_hz must be finite and > 0, got "
                          f"{wheel_radius_m}, {control_rate_hz}")
    need = {"imu": (TIME, "wx", "wy", "wz", "ax", "ay", "az"),
            "wheels": (TIME, "vel_l", "vel_r", "cur_l", "cur_r")}
    for stream, cols in need.items():
        frame = run.streams.get(stream)
        missing = [c for c in cols if frame is None or c not in frame.columns]
        if missing:
            raise MissingColumnError(f"run {run.run_id} has no {stream} channel(s) "
                                     f"{', '.join(missing)}", path=run.source or None,
                                     column=missing[0])
        if run.streams[stream].empty:
            raise DataFormatError(f"run {run.run_id} has no {stream} samples: nothing to "
                                  "replay", path=run.source or None)
        for col in cols:   # text stopped on numpy's bare ValueError, a boolean was read as 1
            _refuse_non_numbers(run, stream, col)
        t = run.streams[stream][TIME].to_numpy(dtype=float)
        bad = times_out_of_order(t, strict=False)
        if bad.size:   # the cuts below search sorted times: a sample out of order is lost
            i = int(bad[0])
            raise DataFormatError(f"run {run.run_id}: {stream} time {t[i]} at row {i} is not "
                                  f"finite or goes back (previous {t[i - 1] if i else 'none'}); "
                                  f"{bad.size} such row(s): the replay needs finite times in "
                                  "order", path=run.source or None, column=TIME, row=i)
    full = run.streams["imu"][list(need["imu"])].to_numpy(dtype=float)
    imu = full[:, [0, 4, 5, 3]]                   # t, ax, ay, wz
    wh = run.streams["wheels"][list(need["wheels"])].to_numpy(dtype=float)
    wheels = np.column_stack([wh[:, 0], wh[:, 1:3] / wheel_radius_m])
    currents = np.column_stack([wh[:, 0], np.abs(wh[:, 3:5])])
    t0, t1 = max(imu[0, 0], wh[0, 0]), min(imu[-1, 0], wh[-1, 0])
    if t1 < t0:   # no call would receive both streams: not one observation, unsaid
        raise ClockError(f"run {run.run_id}: the imu and wheels streams do not overlap in "
                         f"time (imu {imu[0, 0]:.2f}-{imu[-1, 0]:.2f} s, wheels "
                         f"{wh[0, 0]:.2f}-{wh[-1, 0]:.2f} s)", path=run.source or None)
    period = 1.0 / control_rate_hz
    # the call at t1 itself is made within the clock's rounding (1e-9 periods alone: on an
    # epoch clock t1 - t0 rounds by 2.4e-7 s, and the last call was lost by the origin)
    slack = float(clock_slack(max(abs(t0), abs(t1))))
    last = int(np.floor((t1 - t0 + slack) / period + 1e-9))
    data = {"imu": imu, "wheels": wheels, "currents": currents, "imu_full": full}
    before = {name: int(np.searchsorted(data[name][:, 0], t0, side="left"))
              for name in ("imu", "wheels")}
    t_last = t0 + last * period           # (the same call time as the last cut of _calls)
    after = {name: len(data[name]) - int(np.searchsorted(data[name][:, 0], t_last, "right"))
             for name in ("imu", "wheels")}
    return MeasuredObservations(_calls(data, t0, period, last), before, after)


def _refuse_non_numbers(run: Run, stream: str, col: str) -> None:
    """Raise a :class:`~terrain.errors.NonNumericError` naming the run's file, the stream's
    column and the first row whose value is not a real number (text, a boolean); missing
    values (NaN, None) pass, as NaN: the estimators skip and count them."""
    values = run.streams[stream][col]
    if values.dtype.kind in "iuf":
        return
    as_numbers = pd.to_numeric(values, errors="coerce")
    bad = np.flatnonzero((as_numbers.isna() & values.notna()).to_numpy()
                         | values.map(lambda x: isinstance(x, (bool, np.bool_))).to_numpy())
    if bad.size:
        i = int(bad[0])
        raise NonNumericError(f"run {run.run_id}: {stream} value {values.iloc[i]!r:.40} is not "
                              f"a real number; {bad.size} such row(s)",
                              path=run.source or None, column=col, row=i)


def _calls(data: dict[str, np.ndarray], t0: float, period: float, last: int
           ) -> Iterator[Observation]:
    """The calls ``t0 + k period``, ``k = 0..last``, of :func:`measured_observations`, each
    with the rows of ``data`` (stream -> rows ``t, ...``) since the previous call."""
    cuts = dict.fromkeys(data, 0)
    for k in range(last + 1):
        t = t0 + k * period
        taken = {}
        for name, rows in data.items():
            start = cuts[name] if k else int(np.searchsorted(rows[:, 0], t0, side="left"))
            stop = int(np.searchsorted(rows[:, 0], t, side="right"))
            taken[name], cuts[name] = rows[start:stop], stop
        yield Observation(float(t), np.zeros(2), taken["imu"], taken["wheels"],
                          np.zeros((0, 3)), np.zeros((0, 5)), taken["currents"],
                          taken["imu_full"])
