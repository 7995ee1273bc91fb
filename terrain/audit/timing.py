"""Clock offset between the wheel stream and the IMU (effect ``wheel_lag``), per run.

Convention: ``lag_s > 0`` means the wheel stream is *late*: a wheel sample stamped ``t``
describes the robot at IMU time ``t - lag_s`` (the simulator's ``wheel_lag`` effect, where
the ``pro_`` stream at time t holds the true value at t - lag).

Method
------
The yaw rate the wheels command, ``x(t) = (v_R - v_L) / B`` (seed ``000`` eq. 2), and the
gyro ``wz`` (zero-phase low-passed) move together whatever the ICR expansion or gyro bias
are, so for each candidate lag ``L`` the gyro is sampled at ``t - L`` and regressed on ``x``
(``wz = a x + c``); the lag with the best coefficient of determination R^2 wins (grid step
``lag_step_s``, refined by a parabola through the best three points). Scale and offset are
free in this fit, so the lag does not depend on chi or on a gyro bias.

Optionally a second reference, the replayed yaw rate, competes with ``x`` in every window
(the one with the higher R^2 wins): the replay includes the simulated vehicle's response
time, which matters where the simulated robot follows turn commands slowly.

The lag may drift within a run, so it is estimated in overlapping windows (``window_s`` long,
every ``step_s``, closed at both ends; a window whose centre lies past the last sample is
not examined, and where the hop would then leave the run's last samples in no window, the
last window ends on the last sample); a window is used when the commanded yaw rate moves in
it (std of ``x`` >= ``min_excitation_rad_s``), the best fit explains the gyro (R^2 >=
``min_r2``), the slope is positive and the best lag is not at the edge of the search
range (``|lag| >= max_lag_s - 1.5 lag_step_s``: the grid's outermost point, or refined
half a step or more from the next one towards it, may be a maximum cut off by the range).
The lag at any time is interpolated between window centres (constant beyond the first and
last). A run with no usable window has no identifiable lag.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from terrain.errors import ConfigError, DataFormatError, config_positive


@dataclass(frozen=True)
class LagSettings:
    """Settings of the lag estimation.

    Parameters
    ----------
    max_lag_s : float
        Search range ``[-max_lag_s, max_lag_s]``, s.
    lag_step_s : float
        Grid step, s: the candidate lags are whole steps within the range, symmetric about
        0 (:func:`lag_grid`).
    window_s, step_s : float
        Window length and hop, s. Runs shorter than ``window_s`` form one window.
    min_excitation_rad_s : float
        Minimum std of the commanded yaw rate in a window, rad/s.
    min_r2 : float
        Minimum R^2 of the best lag's regression.
    """

    max_lag_s: float = 2.0
    lag_step_s: float = 0.02
    window_s: float = 30.0
    step_s: float = 15.0
    min_excitation_rad_s: float = 0.05
    min_r2: float = 0.5

    def __post_init__(self) -> None:
        """Refuse settings that are not finite numbers in range (ConfigError naming them): NaN
        passed every window's excitation test (``min_excitation_rad_s``) or none's R^2 test
        (``min_r2``), and an infinite ``max_lag_s`` or ``window_s`` searched without end."""
        config_positive("LagSettings", max_lag_s=self.max_lag_s, lag_step_s=self.lag_step_s,
                        window_s=self.window_s, step_s=self.step_s)
        config_positive("LagSettings", allow_zero=True,
                        min_excitation_rad_s=self.min_excitation_rad_s, min_r2=self.min_r2)
        if self.min_r2 > 1.0:
            raise ConfigError(f"LagSettings.min_r2 must be in [0, 1], got {self.min_r2!r}")
        if not 0 < self.lag_step_s < self.max_lag_s:
            raise ConfigError("need 0 < lag_step_s < max_lag_s")
        if not 0 < self.step_s <= self.window_s:
            raise ConfigError("need 0 < step_s <= window_s")


@dataclass(frozen=True)
class LagTrack:
    """Lag of one run's wheel stream behind its IMU, as estimated window by window.

    Attributes
    ----------
    centres_s : ndarray, shape (k,)
        Centre times of the usable windows (wheel clock), s.
    lags_s : ndarray, shape (k,)
        Lag in each usable window, s (positive = wheel data late).
    r2 : ndarray, shape (k,)
        R^2 of each window's best fit.
    n_windows : int
        Windows examined (usable or not).
    """

    centres_s: np.ndarray
    lags_s: np.ndarray
    r2: np.ndarray
    n_windows: int

    @property
    def identifiable(self) -> bool:
        """Whether at least one window gave a lag."""
        return len(self.lags_s) > 0

    @property
    def median_s(self) -> float:
        """Median of the window lags, s (NaN when not identifiable)."""
        return float(np.median(self.lags_s)) if self.identifiable else float("nan")

    def at(self, t_s: np.ndarray) -> np.ndarray:
        """Lag of the wheel stream at given times.

        Parameters
        ----------
        t_s : ndarray, shape (n,)
            Wheel-clock times, s.

        Returns
        -------
        ndarray, shape (n,)
            Lag, s: interpolated between window centres (constant beyond the first and
            last); 0 when the run has no identifiable lag.
        """
        t_s = np.asarray(t_s, dtype=float)
        if not self.identifiable:
            return np.zeros_like(t_s)
        return np.interp(t_s, self.centres_s, self.lags_s)

    def drift_s_per_min(self, min_span_s: float = 45.0) -> float:
        """Drift of the lag within the run.

        Parameters
        ----------
        min_span_s : float
            Shortest span of window centres over which a drift is reported, s.

        Returns
        -------
        float
            Least-squares slope of lag against time, s per minute (NaN unless at least two
            windows span ``min_span_s``).

        Raises
        ------
        ConfigError
            ``min_span_s`` not a finite number >= 0 (a NaN span failed no comparison and
            a drift was fitted over any span).
        """
        config_positive("LagTrack.drift_s_per_min", allow_zero=True, min_span_s=min_span_s)
        if len(self.lags_s) < 2 or np.ptp(self.centres_s) < min_span_s:
            return float("nan")
        return float(np.polyfit(self.centres_s, self.lags_s, 1)[0] * 60.0)

    def summary(self) -> dict:
        """JSON-ready summary of the track.

        Returns
        -------
        dict
            ``lag_s`` (median), ``lag_start_s``, ``lag_end_s``, ``lag_min_s``, ``lag_max_s``
            (s, rounded to ms; None when not identifiable), ``drift_s_per_min``,
            ``n_windows_used``, ``n_windows``, ``identifiable``.
        """
        if not self.identifiable:
            return {"lag_s": None, "lag_start_s": None, "lag_end_s": None, "lag_min_s": None,
                    "lag_max_s": None, "drift_s_per_min": None,
                    "n_windows_used": 0, "n_windows": self.n_windows, "identifiable": False}
        drift = self.drift_s_per_min()
        return {"lag_s": round(self.median_s, 3), "lag_start_s": round(float(self.lags_s[0]), 3),
                "lag_end_s": round(float(self.lags_s[-1]), 3),
                "lag_min_s": round(float(self.lags_s.min()), 3),
                "lag_max_s": round(float(self.lags_s.max()), 3),
                "drift_s_per_min": None if not np.isfinite(drift) else round(drift, 3),
                "n_windows_used": int(len(self.lags_s)), "n_windows": self.n_windows,
                "identifiable": True}


def lag_grid(settings: LagSettings) -> np.ndarray:
    """Candidate lags of :func:`best_lag`: whole grid steps within the search range.

    Parameters
    ----------
    settings : LagSettings
        ``max_lag_s`` and ``lag_step_s``.

    Returns
    -------
    ndarray, shape (2 n + 1,)
        ``k * lag_step_s`` for ``k = -n..n``, ``n = floor(max_lag_s / lag_step_s)``, s:
        symmetric about 0, with 0 on it. A step that divides ``max_lag_s`` reaches both ends
        of the range; one that does not stops at the last whole step inside it (the grid
        was built from ``-max_lag_s`` upward, so max 1.0 s in steps of 0.3 s searched
        -1.0 .. 0.8 s without 0, and a wheel stream 0.1 s early and 0.1 s late came out
        -0.0996 and +0.143 s; steps of 0.4 s searched -1.0, -0.6, -0.2, 0.2, ...).
    """
    n = int(np.floor(settings.max_lag_s / settings.lag_step_s + 1e-9))
    if abs(n * settings.lag_step_s - settings.max_lag_s) <= 1e-9:
        # the step divides the range: the grid as built before, from -max_lag_s upward
        return np.arange(-settings.max_lag_s, settings.max_lag_s + 1e-9, settings.lag_step_s)
    return np.arange(-n, n + 1) * settings.lag_step_s


def _check_series(owner: str, t_s: np.ndarray, x: np.ndarray, t_imu_s: np.ndarray,
                  wz: np.ndarray, empty_stretch: bool = False) -> None:
    """Refuse an empty record or a series whose length is not its clock's (numpy's bare
    IndexError before), naming the array; with ``empty_stretch`` an empty ``t_s`` is a
    stretch without data (a window inside a timestamp gap), not usable but no error."""
    for name, times, values, values_name in (("t_s", t_s, x, "x"),
                                             ("t_imu_s", t_imu_s, wz, "wz")):
        if len(times) == 0 and not (empty_stretch and name == "t_s"):
            raise DataFormatError(f"{owner}: {name} is empty: no record to align")
        if len(values) != len(times):
            raise DataFormatError(f"{owner}: {values_name} has {len(values)} samples, its "
                                  f"clock {name} {len(times)}")


def best_lag(t_s: np.ndarray, x: np.ndarray, t_imu_s: np.ndarray, wz: np.ndarray,
             settings: LagSettings = LagSettings()) -> tuple[float, float, float]:
    """Best lag of one stretch of data.

    Parameters
    ----------
    t_s : ndarray, shape (n,)
        Wheel timestamps, s.
    x : ndarray, shape (n,)
        Commanded yaw rate ``(v_R - v_L) / B`` at ``t_s``, rad/s.
    t_imu_s : ndarray, shape (m,)
        IMU timestamps, s.
    wz : ndarray, shape (m,)
        Low-passed gyro yaw rate, rad/s.
    settings : LagSettings
        Search range and grid step, minimum excitation.

    Returns
    -------
    lag_s : float
        Best lag, s; NaN when the stretch is not usable: fewer than 8 samples whose IMU time
        ``t - lag`` stays inside the IMU record for every candidate lag (``t_s`` within
        ``max_lag_s`` of its ends, both ends included), or their ``x`` with a std below
        ``min_excitation_rad_s``.
    r2 : float
        R^2 of the regression ``wz(t - lag) = a x(t) + c``.
    slope : float
        ``a`` at the best lag.

    Raises
    ------
    DataFormatError
        ``t_imu_s`` empty, or ``x`` (``wz``) not as long as ``t_s`` (``t_imu_s``); an empty
        ``t_s`` (a window inside a gap) is a stretch that is not usable.
    """
    _check_series("best_lag", t_s, x, t_imu_s, wz, empty_stretch=True)
    lags = lag_grid(settings)
    # samples whose IMU time stays inside the IMU record for every candidate lag
    ok = (t_s - settings.max_lag_s >= t_imu_s[0]) & (t_s + settings.max_lag_s <= t_imu_s[-1])
    if ok.sum() < 8 or np.std(x[ok]) < settings.min_excitation_rad_s:
        return float("nan"), float("nan"), float("nan")
    xs = x[ok] - x[ok].mean()
    sxx = float(np.sum(xs * xs))
    ys = np.interp(t_s[ok][None, :] - lags[:, None], t_imu_s, wz)      # (n_lags, n)
    ys = ys - ys.mean(axis=1, keepdims=True)
    syy = np.sum(ys * ys, axis=1)
    sxy = ys @ xs
    r2 = np.where(syy > 0, sxy * sxy / np.maximum(sxx * syy, 1e-300), 0.0)
    r2 = np.where(sxy > 0, r2, 0.0)                   # a negative slope is not a match
    k = int(np.argmax(r2))
    lag = float(lags[k])
    if 0 < k < len(lags) - 1:
        y0, y1, y2 = r2[k - 1], r2[k], r2[k + 1]
        den = y0 - 2.0 * y1 + y2
        if den < 0:
            lag += float(np.clip(0.5 * (y0 - y2) / den, -0.5, 0.5)) * settings.lag_step_s
    return lag, float(r2[k]), float(sxy[k] / sxx)


def estimate_lag_track(t_s: np.ndarray, x: np.ndarray, t_imu_s: np.ndarray, wz: np.ndarray,
                       settings: LagSettings = LagSettings(),
                       alternative: np.ndarray | None = None) -> LagTrack:
    """Window-by-window lag of the wheel stream behind the IMU (module docstring).

    Parameters
    ----------
    t_s : ndarray, shape (n,)
        Wheel timestamps, s.
    x : ndarray, shape (n,)
        Commanded yaw rate ``(v_R - v_L) / B``, rad/s.
    t_imu_s : ndarray, shape (m,)
        IMU timestamps, s.
    wz : ndarray, shape (m,)
        Low-passed gyro yaw rate, rad/s.
    settings : LagSettings
        Windows, search range, acceptance thresholds.
    alternative : ndarray, shape (n,), optional
        A second prediction of the yaw rate at ``t_s`` (the replay's, which includes the
        simulated vehicle's response time); in each window the reference that explains the
        gyro better (higher R^2) sets the lag. On ground where the simulated robot follows
        turn commands slowly (ice) while the data come from that simulator, the replayed yaw
        rate is the right reference; on measured data the command usually is.

    Returns
    -------
    LagTrack

    Raises
    ------
    DataFormatError
        ``t_s`` or ``t_imu_s`` empty, or ``x`` or ``alternative`` (``wz``) not as long as
        ``t_s`` (``t_imu_s``).
    """
    _check_series("estimate_lag_track", t_s, x, t_imu_s, wz)
    if alternative is not None and len(alternative) != len(t_s):
        raise DataFormatError(f"estimate_lag_track: alternative has {len(alternative)} "
                              f"samples, its clock t_s {len(t_s)}")
    t0, t1 = float(t_s[0]), float(t_s[-1])
    if t1 - t0 <= settings.window_s:
        starts = np.array([t0])
        width = t1 - t0 + 1e-9
    else:
        starts = np.arange(t0, t1 - settings.window_s + settings.step_s, settings.step_s)
        starts = starts[starts + 0.5 * settings.window_s < t1]
        if starts[-1] + settings.window_s < t1:
            # a hop longer than half a window dropped the window of the run's tail: the
            # last samples were in none; the last window ends on the last sample instead
            starts = np.r_[starts, t1 - settings.window_s]
        width = settings.window_s
    centres, lags, r2s = [], [], []
    for s in starts:
        m = (t_s >= s) & (t_s <= s + width)
        lag, r2, slope = best_lag(t_s[m], x[m], t_imu_s, wz, settings)
        if alternative is not None:
            alt = best_lag(t_s[m], alternative[m], t_imu_s, wz, settings)
            if np.isfinite(alt[1]) and (not np.isfinite(r2) or alt[1] > r2):
                lag, r2, slope = alt
        at_bound = abs(lag) >= settings.max_lag_s - 1.5 * settings.lag_step_s
        if np.isfinite(lag) and r2 >= settings.min_r2 and slope > 0 and not at_bound:
            centres.append(float(np.mean(t_s[m])))
            lags.append(lag)
            r2s.append(r2)
    return LagTrack(np.asarray(centres), np.asarray(lags), np.asarray(r2s), len(starts))
