"""A run's states and per-wheel slip: the right EKF for the vehicle, lag handling, SAE slip.

``estimate_run`` picks the estimator from ``Run.vehicle``:

* ``agrimaro``: the 12-state EKF of :mod:`terrain.estimation.agrimaro`; slip of wheels 1-3
  (ch. 7.2 numbering, the simulator's) from the raw ``omega`` stream and the EKF velocity
  moved to each wheel with the EKF steering angles (eqs. 7.3-7.5);
* ``husky`` / ``tracked`` (skid-steer): the EKF of :mod:`terrain.estimation.skid_steer`;
  slip of side 1 = left, 2 = right (the simulator's numbering) from the raw ``vel_l``,
  ``vel_r`` and the EKF body velocity moved to the side's geometric contact line
  ``y = +-B/2``. Without an external velocity reference the forward speed is the mean wheel
  speed, so this slip is the part of each side's slip that shows in turning (scrub), not the
  common longitudinal slip.

Encoder lag (``lag``): ``"xcorr"`` (default) estimates it from the data
(:func:`terrain.slip.alignment.estimate_lag`: camera speed vs rim speed for AgriMaRo, gyro
vs wheel yaw rate for skid-steer) and subtracts it from the encoder timestamps; ``"ema"``
applies the thesis's remedy (camera EMA alpha = 0.2, encoders unfiltered, ch. 7.2.2);
``"none"`` does neither.
"""

from __future__ import annotations

from dataclasses import dataclass, field, replace
from typing import Any

import numpy as np
import pandas as pd

from terrain.errors import ConfigError, EstimationError
from terrain.estimation.agrimaro import (AgriMaRoEKFSettings, estimate_agrimaro,
                                         noise_derived_settings)
from terrain.estimation.ekf import Gate
from terrain.estimation.prefilter import robust_noise_std
from terrain.estimation.runner import EKFResult
from terrain.estimation.skid_steer import SkidSteerSettings, estimate_skid_steer
from terrain.run import TIME, Run
from terrain.slip.alignment import LagEstimate, estimate_lag
from terrain.slip.core import DEAD_BAND_M_S, skid_steer_side_slip, wheel_slip
from terrain.vehicles import get_vehicle

LAG_MODES = ("xcorr", "ema", "none")
TUNINGS = ("noise", "thesis")


@dataclass
class RunEstimate:
    """States and slip of one run.

    Attributes
    ----------
    run_id : str
    vehicle : str
    ekf : EKFResult
    slip : ndarray, shape (N, k)
        SAE slip of each wheel / side on the EKF grid.
    slip_names : tuple of str
        ``slip_1``... (simulator numbering).
    lag : LagEstimate or None
        Estimated encoder lag (``lag="xcorr"``).
    meta : dict
        Tuning, lag mode and offsets, dead band.
    """

    run_id: str
    vehicle: str
    ekf: EKFResult
    slip: np.ndarray
    slip_names: tuple[str, ...]
    lag: LagEstimate | None = None
    meta: dict[str, Any] = field(default_factory=dict)

    def to_frame(self) -> pd.DataFrame:
        """``t_s``, states (plus ``icr_chi = exp(log_icr_chi)`` for skid-steer),
        ``std_<state>``, ``slip_i``, ``innov_<row>``, ``nis``, ``nis_dof``."""
        frame = self.ekf.to_frame()
        if "log_icr_chi" in frame.columns:
            frame.insert(frame.columns.get_loc("log_icr_chi") + 1, "icr_chi",
                         np.exp(frame["log_icr_chi"]))
        pos = frame.columns.get_loc("nis") - len(self.ekf.measurement_names)
        for j, name in enumerate(self.slip_names):
            frame.insert(pos + j, name, self.slip[:, j])
        return frame


def _interp_on(t_grid: np.ndarray, t: np.ndarray, values: np.ndarray) -> np.ndarray:
    out = np.empty((t_grid.size, values.shape[1]))
    for j in range(values.shape[1]):
        ok = np.isfinite(values[:, j])
        out[:, j] = (np.interp(t_grid, t[ok], values[ok, j], left=np.nan, right=np.nan)
                     if ok.sum() >= 2 else np.nan)
    return out


def agrimaro_settings(run: Run, tuning: str = "noise") -> AgriMaRoEKFSettings:
    """EKF settings for a run: ``thesis`` (eqs. 6.9, 6.13, 6.14) or ``noise`` (noise-derived,
    the accelerometer variance measured on the run with
    :func:`~terrain.estimation.prefilter.robust_noise_std`).

    Raises
    ------
    ConfigError
        Unknown tuning.
    """
    if tuning == "thesis":
        return AgriMaRoEKFSettings()
    if tuning != "noise":
        raise ConfigError(f"unknown tuning {tuning!r}; valid: {', '.join(TUNINGS)}")
    imu = run.streams.get("imu")
    acc = 0.8
    if imu is not None and len(imu) > 50:
        rate = float(1.0 / np.median(np.diff(imu[TIME].to_numpy())))
        est = np.nanmax(robust_noise_std(imu[["ax", "ay"]].to_numpy(float), rate))
        acc = float(est) if np.isfinite(est) and est > 0 else acc
    return noise_derived_settings(accel_std_m_s2=acc)


def _agrimaro(run: Run, lag: str, tuning: str, gate: Gate | None, rate_hz: float | None,
              store_covariance: bool, settings: AgriMaRoEKFSettings | None) -> RunEstimate:
    params = get_vehicle("agrimaro")
    settings = settings or agrimaro_settings(run, tuning)
    offsets: dict[str, float] = {}
    lag_est = None
    if lag == "ema":
        ema = dict(settings.ema_alpha)
        ema.update(cam=0.2, omega=0.0)
        settings = replace(settings, ema_alpha=tuple(ema.items()))
    omega = run.streams.get("omega")
    if omega is not None:
        t_om = omega[TIME].to_numpy(float)
        om = omega[["omega_1", "omega_2", "omega_3"]].to_numpy(float)
    elif "wheels" in run.streams:
        w = run.streams["wheels"]
        t_om = w[TIME].to_numpy(float)
        om = np.column_stack([w["vel_l"].to_numpy(float), w["vel_r"].to_numpy(float),
                              np.full(len(w), np.nan)]) / params.wheel_radius_m
    else:
        raise EstimationError(f"run {run.run_id} has no wheel-speed stream (omega or wheels)")
    if lag == "xcorr" and "cam" in run.streams:
        cam = run.streams["cam"]
        ref = np.hypot(cam["v_cx"].to_numpy(float), cam["v_cy"].to_numpy(float))
        rim = np.nanmean(np.abs(om), axis=1) * params.wheel_radius_m
        try:
            lag_est = estimate_lag(cam[TIME].to_numpy(float), ref, t_om, rim)
            offsets["omega"] = lag_est.lag_s
        except EstimationError:
            lag_est = None
    ekf = estimate_agrimaro(run, settings, rate_hz=rate_hz, gate=gate, time_offsets_s=offsets,
                            store_covariance=store_covariance)
    rim = _interp_on(ekf.t_s, t_om - offsets.get("omega", 0.0), om) * params.wheel_radius_m
    delta = ekf.x[:, [ekf.state_names.index(f"delta_{i}") for i in (1, 2, 3)]]
    slip = wheel_slip(rim, ekf.state("v_bx"), ekf.state("v_by"), ekf.state("yaw_rate"),
                      params.positions, delta)
    return RunEstimate(run.run_id, "agrimaro", ekf, slip, ("slip_1", "slip_2", "slip_3"),
                       lag_est, {"tuning": settings.name, "lag_mode": lag,
                                 "time_offsets_s": offsets, "dead_band_m_s": DEAD_BAND_M_S})


def _skid_steer(run: Run, lag: str, gate: Gate | None, rate_hz: float | None,
                store_covariance: bool, settings: SkidSteerSettings | None) -> RunEstimate:
    params = get_vehicle(run.vehicle)
    settings = settings or SkidSteerSettings(track_m=params.track_m)
    w = run.streams.get("wheels")
    if w is None:
        raise EstimationError(f"run {run.run_id} has no wheels stream")
    t_w = w[TIME].to_numpy(float)
    vel = w[["vel_l", "vel_r"]].to_numpy(float)
    offsets: dict[str, float] = {}
    lag_est = None
    if lag == "xcorr" and "imu" in run.streams:
        imu = run.streams["imu"]
        try:
            lag_est = estimate_lag(imu[TIME].to_numpy(float), imu["wz"].to_numpy(float), t_w,
                                   (vel[:, 1] - vel[:, 0]) / settings.track_m,
                                   max_lag_s=1.0, rate_hz=50.0)
            offsets["wheels"] = lag_est.lag_s
        except EstimationError:
            lag_est = None
    ekf = estimate_skid_steer(run, settings, rate_hz=rate_hz, gate=gate, time_offsets_s=offsets,
                              store_covariance=store_covariance)
    rim = _interp_on(ekf.t_s, t_w - offsets.get("wheels", 0.0), vel)
    slip = skid_steer_side_slip(rim, ekf.state("v_bx"), ekf.state("yaw_rate"), settings.track_m)
    return RunEstimate(run.run_id, params.name, ekf, slip, ("slip_1", "slip_2"), lag_est,
                       {"tuning": "skid-steer default", "lag_mode": lag,
                        "time_offsets_s": offsets, "dead_band_m_s": DEAD_BAND_M_S})


def estimate_run(run: Run, *, lag: str = "xcorr", tuning: str = "noise",
                 gate: Gate | None = None, rate_hz: float | None = None,
                 store_covariance: bool = False,
                 settings: AgriMaRoEKFSettings | SkidSteerSettings | None = None
                 ) -> RunEstimate:
    """States and per-wheel slip of a run with the estimator of its vehicle.

    Parameters
    ----------
    run : Run
        ``run.vehicle`` selects the estimator (``agrimaro``; ``husky``, ``tracked``).
    lag : {"xcorr", "ema", "none"}
        Encoder lag handling (see the module docstring).
    tuning : {"noise", "thesis"}
        AgriMaRo tuning when ``settings`` is None (:func:`agrimaro_settings`).
    gate : Gate, optional
        Chi-square gating per sensor.
    rate_hz : float, optional
        Filter rate, Hz (default: the IMU rate).
    store_covariance : bool
    settings : AgriMaRoEKFSettings or SkidSteerSettings, optional
        Explicit tuning (overrides ``tuning``).

    Returns
    -------
    RunEstimate

    Raises
    ------
    ConfigError
        Unknown vehicle, lag mode or tuning.
    EstimationError, DataFormatError
        The run lacks the streams its estimator needs.
    """
    if lag not in LAG_MODES:
        raise ConfigError(f"unknown lag mode {lag!r}; valid: {', '.join(LAG_MODES)}")
    vehicle = get_vehicle(run.vehicle).name
    if vehicle == "agrimaro":
        if settings is not None and not isinstance(settings, AgriMaRoEKFSettings):
            raise ConfigError("agrimaro runs need AgriMaRoEKFSettings")
        return _agrimaro(run, lag, tuning, gate, rate_hz, store_covariance, settings)
    if settings is not None and not isinstance(settings, SkidSteerSettings):
        raise ConfigError(f"{vehicle} runs need SkidSteerSettings")
    return _skid_steer(run, lag, gate, rate_hz, store_covariance, settings)
