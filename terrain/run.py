"""The ``Run``: one recorded (or simulated) drive, its metadata and its typed streams.

Contract: every stream is a :class:`pandas.DataFrame` whose first
column is ``t_s`` (time in s, strictly increasing, starting near 0) followed by channels with
canonical snake_case names in SI units:

==========  ==========================================================  ==============
stream      channels                                                    units
==========  ==========================================================  ==============
``imu``     ``wx, wy, wz`` (angular rate), ``ax, ay, az`` (specific      rad/s, m/s^2
            force, body frame)
``wheels``  ``vel_l, vel_r`` (wheel linear speed, left/right side),      m/s, A
            ``cur_l, cur_r`` (motor current)
``truth``   simulator ground truth (pose, body velocities, ``slip_i``)   SI
``steer``   steering angles ``delta_i``                                  rad
``cam``     visual-odometry velocities and yaw rate                      m/s, rad/s
==========  ==========================================================  ==============

The IMU's body frame is x forward, y left, z up: on level ground ``az`` is +9.81 m/s^2, and
``wz`` is positive turning left (counter-clockwise seen from above), when the right side's
wheels run faster than the left's (``vel_r > vel_l``); the simulator writes runs so, the
filters' measurement models (:mod:`terrain.estimation`) read them so, and the readers refuse
an IMU whose z axis points down (:mod:`terrain.io.plausibility`, rule ``imu_axes``).

Streams keep their own time base. Putting them on one clock is the explicit step
:func:`terrain.io.align.align_streams`; placing sample times on a uniform step grid (a
filter's or the simulator's) is :func:`step_index`, the one rule both use. Which sample
times break the contract (not finite, or not after the previous one) is
:func:`times_out_of_order`, the one rule of the readers, the alignment and the filters.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any, Mapping

import numpy as np
import pandas as pd

from terrain.errors import (ConfigError, DataFormatError, MissingColumnError, NonFiniteError,
                            duplicated)

TIME = "t_s"
IMU_CHANNELS = ("wx", "wy", "wz", "ax", "ay", "az")
WHEEL_CHANNELS = ("vel_l", "vel_r", "cur_l", "cur_r")
#: Vehicles a run may name (:attr:`Run.vehicle`); each has a default parameter set in
#: :func:`terrain.vehicles.get_vehicle`, which takes the names from here
VEHICLE_NAMES: tuple[str, ...] = ("agrimaro", "husky", "tracked")


def clock_slack(t_s) -> np.ndarray:
    """Rounding slack of a time comparison near ``t_s``, s: 1 ns, or 64 units in the last
    place of the clock where that is more.

    Two times on one grid (``t0 + k period``) differ from their grid difference by a few
    units in the last place: 2.4e-7 s each on an epoch clock (~1.7e9 s), where a slack of
    1 ns put a sample exactly on a boundary on either side of it by the clock's origin.
    Far below a sample period either way; 1 ns on a clock that starts near 0.

    Parameters
    ----------
    t_s : float or array-like
        Time(s) compared, s.

    Returns
    -------
    ndarray
        Slack, s, of the shape of ``t_s``.
    """
    return np.maximum(1e-9, 64.0 * np.spacing(np.abs(np.asarray(t_s, dtype=float))))


def step_index(t_grid_s: np.ndarray, t_s, clip: bool = False) -> np.ndarray:
    """Step of a time grid each sample time belongs to: the first step at or after it.

    A sample at ``t`` belongs to the first grid time ``>= t``, within :func:`clock_slack`
    of ``t`` (1 ns on clocks below 2**17 s, about 36 h, so on every shipped and simulated
    run; 64 units in the last place beyond, 1.5e-5 s on an epoch clock at 1.7e9 s, where
    one rounding of a time is 2.4e-7 s), so a sample on a step belongs to that step despite
    rounding wherever the clock starts. The project's one placement rule: the
    filters place their measurements on their steps by it
    (:func:`terrain.estimation.runner.sample_steps`), and the simulator's sensors, truth and
    closed-loop logs read the physics step of each sample by it
    (:func:`terrain.sim.sensors.physics_step_index`).

    Parameters
    ----------
    t_grid_s : ndarray, shape (n,)
        Step times, s, increasing (``n >= 1`` when ``clip``).
    t_s : array-like, shape (m,)
        Sample times, s.
    clip : bool
        False: a sample after the last step gets ``n``. True: indices clipped to
        ``0 .. n - 1`` (a sample past the last step reads the last one).

    Returns
    -------
    ndarray of int, shape (m,)
        Step index of each sample.
    """
    t = np.asarray(t_s, dtype=float)
    idx = np.searchsorted(t_grid_s, t - clock_slack(t), side="left")
    return np.clip(idx, 0, len(t_grid_s) - 1) if clip else idx


def times_out_of_order(t_s, strict: bool = True) -> np.ndarray:
    """Rows of a time column that break the ``t_s`` contract: not finite, or not after the
    previous row's time (before it: ``strict=False`` lets a repeated time pass).

    The first row returned is the one an error names; a row after a non-finite time is
    judged by that comparison alone (NaN compares False), so it is not counted again.

    Parameters
    ----------
    t_s : array-like, shape (n,)
        Sample times, s, in row order.
    strict : bool
        True: a time equal to the previous one breaks the contract (the :class:`Run`
        streams'); False: only a time before it does.

    Returns
    -------
    ndarray of int, shape (k,)
        The offending rows, ascending (0-based); empty when every time is in order.
    """
    t = np.asarray(t_s, dtype=float)
    with np.errstate(invalid="ignore"):     # (inf - inf: NaN, judged below)
        step = np.diff(t)
    # (after +inf every step is -inf: judged by the finite check alone, as after NaN)
    back = (step <= 0.0 if strict else step < 0.0) & np.isfinite(t[:-1])
    return np.flatnonzero(~np.isfinite(t) | np.r_[False, back])


@dataclass(frozen=True)
class Run:
    """One run: metadata and named streams.

    Parameters
    ----------
    run_id : str
        Unique id, ``<dataset>/<TERRAIN>/<index>`` for measured runs (e.g.
        ``borealtc/ASPHALT/00``).
    dataset : str
        Dataset name (``borealtc``, ``vulpi``, ``sim``, or the folder name for other roots).
    terrain : str or None
        Terrain class label of the whole run (upper case), ``None`` when unknown.
    streams : Mapping[str, pandas.DataFrame]
        Stream name -> frame with ``t_s`` first and canonical channel columns (SI units).
    vehicle : str
        Vehicle name, one of :data:`VEHICLE_NAMES` (``husky`` for the measured data).
    source : str
        Where the run came from (file path or description).
    meta : Mapping[str, Any]
        Further metadata (sampling rates, simulator settings, repair counts...).
    """

    run_id: str
    dataset: str
    terrain: str | None
    streams: Mapping[str, pd.DataFrame]
    vehicle: str = "husky"
    source: str = ""
    meta: Mapping[str, Any] = field(default_factory=dict)

    @property
    def has_imu(self) -> bool:
        """Whether the run has an IMU stream."""
        return "imu" in self.streams

    @property
    def duration_s(self) -> float:
        """Duration of the wheel stream (or the longest stream), in s; 0 when it (or every
        stream) holds no sample."""
        frame = self.streams.get("wheels")
        frames = [frame] if frame is not None else list(self.streams.values())
        return float(max((f[TIME].iloc[-1] - f[TIME].iloc[0] for f in frames if len(f)),
                         default=0.0))

    def require_columns(self, stream: str, columns) -> pd.DataFrame:
        """A stream's frame, checked to hold ``t_s`` and ``columns``.

        Parameters
        ----------
        stream : str
            Stream name, a key of :attr:`streams` (e.g. ``"imu"``).
        columns : iterable of str
            Channel names the caller reads.

        Returns
        -------
        pandas.DataFrame
            The stream's frame.

        Raises
        ------
        KeyError
            If the run has no such stream.
        MissingColumnError
            The frame lacks ``t_s`` or one of ``columns`` (run, stream and the missing
            columns named; a :class:`~terrain.errors.DataFormatError`).
        """
        frame = self.streams[stream]
        missing = [c for c in (TIME, *columns) if c not in frame.columns]
        if missing:
            raise MissingColumnError(f"run {self.run_id}: stream {stream!r} lacks columns "
                                     f"{missing}", self.source, missing[0])
        return frame

    def require_finite(self, stream: str, columns) -> None:
        """Refuse a stream whose ``t_s`` or named columns hold a NaN or infinite value.

        For callers that cannot skip a sample: the audit's replay integrates the wheel
        speeds, and its frames low-pass the IMU channels, where one non-finite sample ends
        in the integrator's error or spreads over the whole filtered record.

        Parameters
        ----------
        stream : str
            Stream name, a key of :attr:`streams`.
        columns : iterable of str
            Columns checked after ``t_s`` (present: :meth:`require_columns` first).

        Raises
        ------
        NonFiniteError
            A column holds a non-finite value (run, stream, column, count and first row
            named; a :class:`~terrain.errors.DataFormatError`).
        """
        frame = self.streams[stream]
        for col in (TIME, *columns):
            bad = np.flatnonzero(~np.isfinite(frame[col].to_numpy(dtype=float)))
            if bad.size:
                raise NonFiniteError(f"run {self.run_id}: {bad.size} non-finite value(s) in "
                                     f"{stream} column {col!r}, first at row {bad[0]}",
                                     self.source, col, int(bad[0]))

    def rate_hz(self, stream: str) -> float:
        """Median sampling rate of ``stream`` in Hz.

        Parameters
        ----------
        stream : str
            Stream name, a key of :attr:`streams` (e.g. ``"imu"``, ``"wheels"``).

        Returns
        -------
        float
            1 / median of the time steps of the stream's ``t_s`` column, Hz.

        Raises
        ------
        KeyError
            If the run has no such stream.
        DataFormatError
            The stream has fewer than 2 samples (no step: the rate was NaN without a
            word), or its median time step is not finite and > 0 (times repeated, going
            back, NaN or infinite: :func:`times_out_of_order`), naming the run, the stream,
            the run's source and the first row out of order.
        """
        t = self.streams[stream][TIME].to_numpy()
        if t.size < 2:
            raise DataFormatError(f"run {self.run_id}: stream {stream!r} has {t.size} "
                                  f"sample(s): no time step to give a rate", self.source, TIME)
        step = float(pd.Series(t).diff().median())
        if not 0.0 < step < np.inf:     # (a Run built in memory is not checked)
            bad = times_out_of_order(t)
            raise DataFormatError(f"run {self.run_id}: stream {stream!r} has no positive "
                                  f"finite median time step (median {step!r} s): no rate",
                                  self.source, TIME, int(bad[0]) if bad.size else None)
        return 1.0 / step


def runs_by_id(runs, owner: str) -> dict[str, Run]:
    """The runs keyed by their id, each id once.

    Parameters
    ----------
    runs : iterable of Run
        The runs given.
    owner : str
        The function's name, for the message.

    Returns
    -------
    dict of str to Run

    Raises
    ------
    ConfigError
        Two runs share an id (a dict kept the last one without a word, and the windows of
        the other were scored on it).
    """
    runs = list(runs)
    repeated = duplicated(r.run_id for r in runs)
    if repeated:
        raise ConfigError(f"{owner}: run id(s) {repeated[:5]} given more than once (each "
                          "run once: its windows are looked up by id)")
    return {r.run_id: r for r in runs}
