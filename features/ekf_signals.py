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

The estimator is causal (each value depends on the run's past only) and uses no label, so
the channels can be computed before a run-grouped split without leakage. Grid rows inside a
gap (NaN) are skipped by the filter and stay NaN in every EKF channel, so the windowing step
drops the windows that contain them, as for the raw channels.
"""

from __future__ import annotations

import numpy as np
import pandas as pd

from terrain.estimation.skid_steer import SkidSteerSettings, icr_chi, skid_steer_on_frame
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
    gap = ~np.isfinite(frame[["vel_l", "vel_r", "wz"]].to_numpy(float)).all(axis=1)
    slip = skid_steer_side_slip(frame[["vel_l", "vel_r"]].to_numpy(float), res.state("v_bx"),
                                res.state("yaw_rate"), settings.track_m)
    y = np.where(res.accepted, res.y, np.nan)
    cols = {"ekf_v_bx": res.state("v_bx"), "ekf_yaw_rate": res.state("yaw_rate"),
            "ekf_gyro_bias": res.state("gyro_bias"), "ekf_icr_chi": icr_chi(res),
            "ekf_innov_vel_l": y[:, 0], "ekf_innov_vel_r": y[:, 1], "ekf_innov_wz": y[:, 2],
            "ekf_nis": res.nis, "ekf_slip_l": slip[:, 0], "ekf_slip_r": slip[:, 1]}
    out = pd.DataFrame(cols, index=frame.index)
    out.loc[gap, :] = np.nan
    return out[list(EKF_CHANNELS)]


def add_ekf_channels(frame: pd.DataFrame, *, wheel_rate_hz: float | None = None,
                     settings: SkidSteerSettings = SkidSteerSettings(track_m=HUSKY.track_m)
                     ) -> pd.DataFrame:
    """A copy of the aligned ``frame`` with :data:`EKF_CHANNELS` appended.

    Frames without ``vel_l``, ``vel_r`` or ``wz`` (or shorter than 2 rows) are returned
    unchanged (the windowing step then reports the missing channels). See
    :func:`ekf_channel_frame`.

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
        ``frame`` with the EKF channels as extra columns, or ``frame`` itself.
    """
    if not {TIME, "vel_l", "vel_r", "wz"} <= set(frame.columns) or len(frame) < 2:
        return frame
    ekf = ekf_channel_frame(frame, wheel_rate_hz=wheel_rate_hz, settings=settings)
    return pd.concat([frame, ekf], axis=1)
