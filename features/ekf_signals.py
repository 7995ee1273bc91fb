"""EKF-derived channels for the window features (signal set ``ekf``).

:func:`add_ekf_channels` runs the skid-steer EKF of :mod:`terrain.estimation.skid_steer` on an
aligned frame (IMU + wheels on one clock, :mod:`terrain.io.align`) and adds these channels,
SI units:

=====================  ======  ==============================================================
channel                unit    meaning
=====================  ======  ==============================================================
``ekf_v_bx``           m/s     body forward speed
``ekf_yaw_rate``       rad/s   yaw rate (gyro corrected for the estimated bias)
``ekf_gyro_bias``      rad/s   gyro z bias
``ekf_icr_chi``        1       ICR expansion factor (turning resistance of the terrain)
``ekf_innov_vel_l``    m/s     innovation of the left wheel speed
``ekf_innov_vel_r``    m/s     innovation of the right wheel speed
``ekf_innov_wz``       rad/s   innovation of the gyro
``ekf_nis``            1       normalised innovation squared of the step
``ekf_slip_l``         1       SAE slip of the left side (:func:`terrain.slip.sae_slip`)
``ekf_slip_r``         1       SAE slip of the right side
=====================  ======  ==============================================================

:func:`window_ekf_channels` computes the same channels from each window's own samples (the
filter started from its prior at the window's first sample), for models that must not carry
state across windows (:class:`terrain.models.window_ekf.WindowEKFClassifier`, ``--window-ekf``).

The estimator is causal (each value depends on the run's past only) and uses no label, so
the channels can be computed before a run-grouped split without leakage. Grid rows inside a
gap (NaN) are skipped by the filter and stay NaN in every EKF channel, so the windowing step
drops the windows that contain them, as for the raw channels.
"""

from __future__ import annotations

from typing import Sequence

import numpy as np
import pandas as pd

from terrain.errors import (DataFormatError, EstimationError, ShapeError, duplicated,
                            real_arrays)
from terrain.estimation.skid_steer import (MEASUREMENT_NAMES, STATE_NAMES, SkidSteerSettings,
                                           skid_steer_on_frame, skid_steer_on_windows)
from terrain.run import TIME
from terrain.slip import skid_steer_side_slip
from terrain.vehicles import HUSKY

EKF_CHANNELS: tuple[str, ...] = ("ekf_v_bx", "ekf_yaw_rate", "ekf_gyro_bias", "ekf_icr_chi",
                                 "ekf_innov_vel_l", "ekf_innov_vel_r", "ekf_innov_wz",
                                 "ekf_nis", "ekf_slip_l", "ekf_slip_r")
#: Streams the EKF channels need.
EKF_STREAMS: tuple[str, ...] = ("imu", "wheels")


def ekf_channel_frame(frame: pd.DataFrame, *, wheel_rate_hz: float | None = None,
                      settings: SkidSteerSettings = SkidSteerSettings(track_m=HUSKY.track_m)
                      ) -> pd.DataFrame:
    """The EKF channels of an aligned frame.

    Parameters
    ----------
    frame : pandas.DataFrame
        Aligned frame with ``t_s``, ``vel_l``, ``vel_r`` (m/s) and ``wz`` (rad/s).
    wheel_rate_hz : float, optional
        Native rate of the wheel stream (the wheel variance is inflated by grid rate / native
        rate, see :func:`~terrain.estimation.skid_steer.skid_steer_on_frame`).
    settings : SkidSteerSettings
        Husky geometry and tuning by default.

    Returns
    -------
    pandas.DataFrame
        ``(n_samples, len(EKF_CHANNELS))``, same index as ``frame``; NaN where the frame has
        a gap.

    Raises
    ------
    terrain.errors.DataFormatError
        Missing ``vel_l``, ``vel_r`` or ``wz``.
    """
    res = skid_steer_on_frame(frame, settings, wheel_rate_hz=wheel_rate_hz)
    gap = ~np.isfinite(frame[list(MEASUREMENT_NAMES)].to_numpy(float)).all(axis=1)
    cols = _channel_columns(frame[["vel_l", "vel_r"]].to_numpy(float), res.x,
                            np.where(res.accepted, res.y, np.nan), res.nis, res.state_names,
                            settings.track_m)
    out = pd.DataFrame(cols, index=frame.index)
    out.loc[gap, :] = np.nan
    return out[list(EKF_CHANNELS)]


def window_ekf_channels(X: np.ndarray, channels: Sequence[str], rate_hz: float, *,
                        wheel_rate_hz: float | None = None,
                        settings: SkidSteerSettings = SkidSteerSettings(track_m=HUSKY.track_m)
                        ) -> np.ndarray:
    """The EKF channels of each window from its own samples only.

    The filter starts from its prior at each window's first sample, so no state older than
    the window enters (nothing carries across a terrain switch, unlike the filter over a
    whole run of :func:`add_ekf_channels`). Each window gives what :func:`ekf_channel_frame`
    gives on a frame holding only that window (equal to round-off, tested), through the
    lean batch path :func:`~terrain.estimation.skid_steer.skid_steer_on_windows`.

    Parameters
    ----------
    X : numpy.ndarray
        ``(n_windows, n_channels, n_samples)``, ``n_samples >= 2``, gap-free aligned
        windows holding ``vel_l``, ``vel_r`` (m/s) and ``wz`` (rad/s) among their channels.
    channels : sequence of str
        Channel names of axis 1 of ``X``.
    rate_hz : float
        Sampling rate of the windows, Hz.
    wheel_rate_hz : float, optional
        Native rate of the wheel stream, Hz (wheel variance inflation).
    settings : SkidSteerSettings
        Husky geometry and tuning by default.

    Returns
    -------
    numpy.ndarray
        ``(n_windows, len(EKF_CHANNELS), n_samples)``, channels in :data:`EKF_CHANNELS`
        order.

    Raises
    ------
    terrain.errors.DataFormatError
        ``channels`` lacks ``vel_l``, ``vel_r`` or ``wz``, or names one of them twice (the
        channels are read by position), or ``X`` does not convert to real numbers (text).
    terrain.errors.EstimationError
        ``X`` holds booleans (a mask: cast, they ran the filter on speeds of 0 and 1 m/s).
    terrain.errors.ShapeError, terrain.errors.NonFiniteInputError
        ``X`` not 3-D or of windows of fewer than 2 samples (the filter needs a step), or
        a non-finite sample.
    """
    names = list(channels)
    missing = [c for c in MEASUREMENT_NAMES if c not in names]
    if missing:
        raise DataFormatError(f"EKF channels need {missing} among the window channels "
                              f"{names}", None, missing[0])
    twice = [c for c in duplicated(names) if c in MEASUREMENT_NAMES]
    if twice:      # the first of two was read, the other ignored without a word
        raise DataFormatError(f"EKF channels: {twice} named twice among the window channels "
                              f"{names}", None, twice[0])
    X, = real_arrays("window_ekf_channels", EstimationError, X=X)
    if X.ndim != 3 or X.shape[1] != len(names):
        raise ShapeError(f"X must be (n_windows, {len(names)}, n_samples), got {X.shape}")
    # the filter's measurement rows in its own order (its innovations come in that order)
    x, y, nis = skid_steer_on_windows(X[:, [names.index(c) for c in MEASUREMENT_NAMES], :],
                                      rate_hz, settings, wheel_rate_hz=wheel_rate_hz)
    n_win, n = X.shape[0], X.shape[2]
    sides = [names.index("vel_l"), names.index("vel_r")]
    vel = np.moveaxis(X[:, sides, :], 1, 2).reshape(-1, 2)
    cols = _channel_columns(vel, x.reshape(-1, x.shape[2]), y.reshape(-1, y.shape[2]),
                            nis.reshape(-1), STATE_NAMES, settings.track_m)
    return np.stack([cols[c].reshape(n_win, n) for c in EKF_CHANNELS], axis=1)


def _channel_columns(vel: np.ndarray, x: np.ndarray, y: np.ndarray, nis: np.ndarray,
                     state_names: Sequence[str], track_m: float) -> dict[str, np.ndarray]:
    """:data:`EKF_CHANNELS` from the filter's per-step arrays (one equation for both paths).

    ``vel`` ``(N, 2)`` wheel speeds m/s (left, right), ``x`` ``(N, 4)`` states, ``y``
    ``(N, 3)`` innovations in the filter's measurement order
    (:data:`~terrain.estimation.skid_steer.MEASUREMENT_NAMES`; NaN where a row was not used),
    ``nis`` ``(N,)``; returns name -> ``(N,)`` array.
    """
    state = {name: x[:, i] for i, name in enumerate(state_names)}
    slip = skid_steer_side_slip(vel, state["v_bx"], state["yaw_rate"], track_m)
    return {"ekf_v_bx": state["v_bx"], "ekf_yaw_rate": state["yaw_rate"],
            "ekf_gyro_bias": state["gyro_bias"],
            "ekf_icr_chi": np.exp(state["log_icr_chi"]),      # the state is ln(chi)
            **{f"ekf_innov_{name}": y[:, i] for i, name in enumerate(MEASUREMENT_NAMES)},
            "ekf_nis": nis, "ekf_slip_l": slip[:, 0], "ekf_slip_r": slip[:, 1]}


def add_ekf_channels(frame: pd.DataFrame, *, wheel_rate_hz: float | None = None,
                     settings: SkidSteerSettings = SkidSteerSettings(track_m=HUSKY.track_m)
                     ) -> pd.DataFrame:
    """A copy of the aligned ``frame`` with :data:`EKF_CHANNELS` appended.

    Frames without ``vel_l``, ``vel_r`` or ``wz`` are returned unchanged; a frame shorter
    than 2 rows (too short for the filter and for any window) gets the EKF channels as NaN,
    so the windowing step lists its run as too short. See :func:`ekf_channel_frame`.

    Parameters
    ----------
    frame : pandas.DataFrame
        Aligned frame (``t_s``, ``vel_l``, ``vel_r`` m/s, ``wz`` rad/s, ...).
    wheel_rate_hz : float, optional
        Native rate of the wheel stream, Hz.
    settings : SkidSteerSettings
        Husky geometry and tuning by default.

    Returns
    -------
    pandas.DataFrame
        ``frame`` with the EKF channels as extra columns (those it already held, from an
        earlier pass, replaced: the step is idempotent), or ``frame`` itself.
    """
    if not {TIME, "vel_l", "vel_r", "wz"} <= set(frame.columns):
        return frame
    # channels of an earlier pass are replaced (appended again, each name occurred twice)
    frame = frame.drop(columns=[c for c in EKF_CHANNELS if c in frame.columns])
    if len(frame) < 2:
        return pd.concat([frame, pd.DataFrame(np.nan, index=frame.index,
                                              columns=list(EKF_CHANNELS))], axis=1)
    ekf = ekf_channel_frame(frame, wheel_rate_hz=wheel_rate_hz, settings=settings)
    return pd.concat([frame, ekf], axis=1)
