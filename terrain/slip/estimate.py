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
  common longitudinal slip. :func:`estimate_skid_steer_slip_run` supplies that: the EKF of
  :mod:`terrain.estimation.skid_steer_slip` with a slip model (physics, learned or both) as
  pseudo-measurement and the accelerometer, reporting ``slip_i`` with ``std_slip_i``.

Encoder lag (``lag``): ``"xcorr"`` (default) estimates it from the data
(:func:`terrain.slip.alignment.gated_lag`: camera speed vs rim speed for AgriMaRo, gyro
vs wheel yaw rate for skid-steer) and, where the cross-correlation has a clear peak,
subtracts it from the encoder timestamps (otherwise no lag, and a note says why); ``"ema"``
applies the thesis's remedy (camera EMA alpha = 0.2, encoders unfiltered, ch. 7.2.2);
``"none"`` does neither.
"""

from __future__ import annotations

from dataclasses import dataclass, field, replace
from typing import Any

import numpy as np
import pandas as pd

from terrain.errors import (ConfigError, EstimationError, ShapeError, TimeStepError,
                            config_numbers)
from terrain.estimation.agrimaro import (AgriMaRoEKFSettings, estimate_agrimaro,
                                         noise_derived_settings)
from terrain.estimation.ekf import Gate
from terrain.estimation.prefilter import robust_noise_std
from terrain.estimation.result import EKFResult
from terrain.estimation.runner import check_rate_hz, clock_rate_hz
from terrain.estimation.skid_steer import SkidSteerSettings, estimate_skid_steer
from terrain.estimation.skid_steer_slip import SkidSteerSlipSettings
from terrain.run import TIME, Run, times_out_of_order
from terrain.slip.alignment import LagEstimate, gated_lag, lag_not_estimated
from terrain.slip.core import (DEAD_BAND_M_S, sae_slip, skid_steer_contact_lines_m,
                               skid_steer_side_slip, wheel_longitudinal_velocity)
from terrain.terramechanics.slip import in_dead_band
from terrain.vehicles import get_vehicle
from terrain.vehicles.swerve import AGRIMARO, AgriMaRoParams

LAG_MODES = ("xcorr", "ema", "none")
TUNINGS = ("noise", "thesis")


def _check_lag(lag: str) -> None:
    # an unknown mode (a typo, "XCORR") was taken as "none" without a word
    if lag not in LAG_MODES:
        raise ConfigError(f"unknown lag mode {lag!r}; valid: {', '.join(LAG_MODES)}")


@dataclass
class RunEstimate:
    """States and slip of one run.

    Attributes
    ----------
    run_id : str
        ``<dataset>/<terrain>/<index>``.
    vehicle : str
        Vehicle name (:data:`terrain.vehicles.VEHICLE_NAMES`).
    ekf : EKFResult
        The filter's states, covariances and innovations.
    slip : ndarray, shape (N, k)
        SAE slip of each wheel / side on the EKF grid.
    slip_names : tuple of str
        ``slip_1``... (simulator numbering).
    lag : LagEstimate or None
        Estimated encoder lag (``lag="xcorr"``; None for another lag mode); applied only
        where ``lag.applied`` (:func:`~terrain.slip.alignment.gated_lag`); ``lag.estimated``
        False, with ``lag.reason``, when none could be estimated.
    meta : dict
        Tuning, lag mode and offsets, dead band.
    slip_std : ndarray, shape (N, k), optional
        Standard deviation of each slip column (``std_slip_i``); NaN where not propagated
        and, for the AgriMaRo, in the dead band, where the slip is 0 by convention.
    notes : tuple of str
        One-line notes for the user (e.g. which model supplies an unobservable slip).
    """

    run_id: str
    vehicle: str
    ekf: EKFResult
    slip: np.ndarray
    slip_names: tuple[str, ...]
    lag: LagEstimate | None = None
    meta: dict[str, Any] = field(default_factory=dict)
    slip_std: np.ndarray | None = None
    notes: tuple[str, ...] = ()

    def to_frame(self) -> pd.DataFrame:
        """The run's table (the columns of ``terrain estimate``).

        Returns
        -------
        pandas.DataFrame
            ``t_s``, states (plus ``icr_chi = exp(log_icr_chi)`` for skid-steer), ``std_<state>``,
            ``slip_i`` and ``std_slip_i``, ``innov_<row>``, ``nis``, ``nis_dof``; one row per EKF
            step.
        """
        frame = self.ekf.to_frame()
        if "log_icr_chi" in frame.columns:
            frame.insert(frame.columns.get_loc("log_icr_chi") + 1, "icr_chi",
                         np.exp(frame["log_icr_chi"]))
        frame = frame.drop(columns=[c for n in self.slip_names for c in (n, f"std_{n}")
                                    if c in frame.columns])
        pos = frame.columns.get_loc("nis") - len(self.ekf.measurement_names)
        std = self.slip_std if self.slip_std is not None else np.full_like(self.slip, np.nan)
        for j, name in enumerate(self.slip_names):
            frame.insert(pos + 2 * j, name, self.slip[:, j])
            frame.insert(pos + 2 * j + 1, f"std_{name}", std[:, j])
        return frame

    def summary(self) -> str:
        """One line for the log: steps and rate, mean NIS and dof (both over the steps with an
        update), median slip of each wheel, encoder lag (or that it was not applied),
        samples holding a non-finite value (``counts[sensor]["non_finite"]``: those values are
        skipped, the sample's finite rows still used), samples a later one in the same filter
        step superseded
        (a ``rate_hz`` below a sensor's rate), samples outside the filter's time span (a
        stream that starts before or ends after the grid), samples the chi-square gate
        rejected (``gate``; ``counts[sensor]["rejected"]``).

        Returns
        -------
        str
        """
        ekf = self.ekf
        nis = np.nanmean(ekf.nis) if np.isfinite(ekf.nis).any() else float("nan")
        # both over the steps with an update (a step without one has NIS NaN and dof 0)
        updated = np.asarray(ekf.dof) > 0
        dof = float(np.mean(ekf.dof[updated])) if updated.any() else float("nan")
        std = self.slip_std if self.slip_std is not None else np.full_like(self.slip, np.nan)
        slips = ", ".join(
            (f"{n} {np.nanmedian(self.slip[:, j]):+.3f}"
             + (f" (std {np.nanmedian(std[:, j]):.3f})" if np.isfinite(std[:, j]).any()
                else "")) if np.isfinite(self.slip[:, j]).any()
            else f"{n} none (no finite estimate)"
            for j, n in enumerate(self.slip_names))
        lag = ("not estimated" if self.lag is None or not self.lag.estimated
               else f"{self.lag.lag_s:.3f} s" if self.lag.applied
               else f"not applied (no clear peak: {self.lag.lag_s:+.3f} s)")
        skipped = {k: v["non_finite"] for k, v in ekf.counts.items() if v["non_finite"]}
        # a filter slower than a sensor keeps the latest of its samples in each step
        superseded = {k: f"{v['superseded']} of {v['samples']}"
                      for k, v in ekf.counts.items() if v.get("superseded")}
        # a stream that starts before or ends after the filter's grid loses those samples
        outside = {k: f"{v['outside']} of {v['samples']}"
                   for k, v in ekf.counts.items() if v.get("outside")}
        # a gated filter drops the measurements whose innovation fails the chi-square test
        rejected = {k: f"{v['rejected']} of {v['samples']}"
                    for k, v in ekf.counts.items() if v.get("rejected")}
        return (f"{self.run_id} ({self.vehicle}): {ekf.t_s.size} steps at "
                f"{ekf.meta['rate_hz']:.1f} Hz, mean NIS {nis:.2f} (mean dof "
                f"{dof:.2f}), median {slips}, encoder lag {lag}"
                + (f", samples holding a non-finite value (those values skipped) {skipped}"
                   if skipped else "")
                + (f", samples unused (a later one in the same filter step wins) "
                   f"{superseded}" if superseded else "")
                + (f", samples outside the filter's time span (dropped) {outside}"
                   if outside else "")
                + (f", samples rejected by the gate {rejected}" if rejected else ""))


def resample(t_grid_s: np.ndarray, t_s: np.ndarray, values: np.ndarray) -> np.ndarray:
    """Linear interpolation of each column of ``values`` onto ``t_grid_s``.

    Parameters
    ----------
    t_grid_s : ndarray, shape (N,)
        Target times, s.
    t_s : ndarray, shape (k,)
        Sample times, s, increasing.
    values : ndarray, shape (k, c)
        Samples (any unit); non-finite samples are skipped per column.

    Returns
    -------
    ndarray, shape (N, c)
        NaN outside a column's finite samples, and everywhere for a column with fewer than
        two of them.

    Raises
    ------
    ShapeError
        ``values`` is not 2-D with one row per ``t_s`` sample.
    TimeStepError
        A ``t_s`` sample not finite or before the previous one (:func:`np.interp` read them
        silently wrong); the first such sample and the count are named.
    """
    t_s = np.asarray(t_s, dtype=float)
    values = np.asarray(values, dtype=float)
    if values.ndim != 2 or t_s.shape != values.shape[:1]:
        raise ShapeError(f"resample: values must have shape ({t_s.size}, c) for t_s of shape "
                         f"{t_s.shape}, got {values.shape}")
    bad = times_out_of_order(t_s, strict=False)
    if bad.size:
        raise TimeStepError(f"resample: t_s must be finite and increasing: sample {bad[0]} "
                            f"({t_s[bad[0]]:.6g} s) is not, {bad.size} such sample(s) in all")
    out = np.empty((t_grid_s.size, values.shape[1]))
    for j in range(values.shape[1]):
        ok = np.isfinite(values[:, j])
        out[:, j] = (np.interp(t_grid_s, t_s[ok], values[ok, j], left=np.nan, right=np.nan)
                     if ok.sum() >= 2 else np.nan)
    return out


def agrimaro_wheel_speeds(run: Run, vehicle: AgriMaRoParams = AGRIMARO
                          ) -> tuple[np.ndarray, np.ndarray]:
    """Raw wheel angular speeds of an AgriMaRo run (the slip needs the unfiltered encoder,
    seed 001 ch. 7.2).

    Parameters
    ----------
    run : Run
        With an ``omega`` stream (``omega_1..3``, rad/s) or, failing that, a ``wheels`` stream
        (``vel_l``, ``vel_r``, m/s: wheels 1 and 2; wheel 3 NaN).
    vehicle : AgriMaRoParams
        Wheel radius for the ``wheels`` fallback, m.

    Returns
    -------
    t_s : ndarray, shape (k,)
        Sample times, s.
    omega_rad_s : ndarray, shape (k, 3)
        Wheel speeds, rad/s.

    Raises
    ------
    EstimationError
        Neither stream is present.
    """
    omega = run.streams.get("omega")
    if omega is not None:
        return (omega[TIME].to_numpy(float),
                omega[["omega_1", "omega_2", "omega_3"]].to_numpy(float))
    if "wheels" in run.streams:
        w = run.streams["wheels"]
        om = np.column_stack([w["vel_l"].to_numpy(float), w["vel_r"].to_numpy(float),
                              np.full(len(w), np.nan)]) / vehicle.wheel_radius_m
        return w[TIME].to_numpy(float), om
    raise EstimationError(f"run {run.run_id} has no wheel-speed stream (omega or wheels)")


def agrimaro_encoder_lag(run: Run, t_s: np.ndarray, omega_rad_s: np.ndarray,
                         vehicle: AgriMaRoParams = AGRIMARO) -> LagEstimate:
    """Encoder lag of an AgriMaRo run: camera speed ``|v_c|`` against the mean rim speed
    (:func:`~terrain.slip.alignment.gated_lag`: applied only for a clear peak).

    Parameters
    ----------
    run : Run
        Its ``cam`` stream (``v_cx``, ``v_cy``, m/s) is the reference.
    t_s : ndarray, shape (k,)
        Encoder times, s.
    omega_rad_s : ndarray, shape (k, 3)
        Raw wheel speeds, rad/s (:func:`agrimaro_wheel_speeds`).
    vehicle : AgriMaRoParams
        Wheel radius, m.

    Returns
    -------
    LagEstimate
        ``applied`` False (and ``reason``) when the peak is not clear;
        :func:`~terrain.slip.alignment.lag_not_estimated` (``estimated`` False, ``reason``)
        without a camera stream or when no lag can be estimated.
    """
    cam = run.streams.get("cam")
    if cam is None:
        return lag_not_estimated("no cam stream, the reference speed")
    ref = np.hypot(cam["v_cx"].to_numpy(float), cam["v_cy"].to_numpy(float))
    rim = np.nanmean(np.abs(omega_rad_s), axis=1) * vehicle.wheel_radius_m
    try:
        return gated_lag(cam[TIME].to_numpy(float), ref, t_s, rim)
    except EstimationError as exc:
        return lag_not_estimated(str(exc))


def skid_steer_encoder_lag(run: Run, track_m: float) -> LagEstimate:
    """Wheel-stream lag of a skid-steer run: gyro yaw rate against the wheel yaw rate
    ``(vel_r - vel_l) / B`` (:func:`~terrain.slip.alignment.gated_lag`, up to 1 s, 50 Hz:
    applied only for a clear peak).

    Parameters
    ----------
    run : Run
        With ``wheels`` (``vel_l``, ``vel_r``, m/s) and ``imu`` (``wz``, rad/s) streams.
    track_m : float
        Track width B, m.

    Returns
    -------
    LagEstimate
        ``applied`` False (and ``reason``) when the peak is not clear;
        :func:`~terrain.slip.alignment.lag_not_estimated` (``estimated`` False, ``reason``)
        without both streams or when no lag can be estimated.
    """
    w, imu = run.streams.get("wheels"), run.streams.get("imu")
    if w is None or imu is None:
        missing = " and ".join(n for n, s in (("wheels", w), ("imu", imu)) if s is None)
        return lag_not_estimated(f"no {missing} stream (gyro yaw rate against wheel yaw rate)")
    vel = w[["vel_l", "vel_r"]].to_numpy(float)
    try:
        return gated_lag(imu[TIME].to_numpy(float), imu["wz"].to_numpy(float),
                         w[TIME].to_numpy(float), (vel[:, 1] - vel[:, 0]) / track_m,
                         max_lag_s=1.0, rate_hz=50.0)
    except EstimationError as exc:
        return lag_not_estimated(str(exc))


def lag_notes(run: Run, lag_est: LagEstimate | None) -> tuple[str, ...]:
    """The note for a cross-correlation lag that was estimated but not applied.

    Parameters
    ----------
    run : Run
        The run (its id names it).
    lag_est : LagEstimate or None
        :func:`agrimaro_encoder_lag` or :func:`skid_steer_encoder_lag`.

    Returns
    -------
    tuple of str
        One ``note: ...`` when ``lag_est.applied`` is False (with its estimate, or that none
        could be made, and why); empty otherwise.
    """
    if lag_est is None or lag_est.applied:
        return ()
    if not lag_est.estimated:
        return (f"note: encoder lag of run {run.run_id} not estimated (no lag applied): "
                f"{lag_est.reason}",)
    return (f"note: encoder lag of run {run.run_id} not applied (no lag): the "
            f"cross-correlation peak at {lag_est.lag_s:+.3f} s is not clear "
            f"({lag_est.reason})",)


def with_camera_ema(settings: AgriMaRoEKFSettings) -> AgriMaRoEKFSettings:
    """The thesis's lag remedy (seed 001 ch. 7.2.2, eq. 7.8): camera EMA ``alpha = 0.2``,
    encoders unfiltered, other sensors as in ``settings``.

    Parameters
    ----------
    settings : AgriMaRoEKFSettings
        Tuning to modify.

    Returns
    -------
    AgriMaRoEKFSettings
    """
    ema = dict(settings.ema_alpha)
    ema.update(cam=0.2, omega=0.0)
    return replace(settings, ema_alpha=tuple(ema.items()))


def agrimaro_settings(run: Run, tuning: str = "noise") -> AgriMaRoEKFSettings:
    """EKF settings for a run: ``thesis`` (seed 001 eqs. 6.9, 6.13, 6.14) or ``noise``
    (noise-derived, :func:`~terrain.estimation.agrimaro.noise_derived_settings`, with the
    accelerometer noise measured on the run by
    :func:`~terrain.estimation.prefilter.robust_noise_std`; 0.8 m/s^2 when the run has fewer
    than 51 IMU samples).

    Parameters
    ----------
    run : Run
        The run (its ``imu`` stream, ``ax``, ``ay`` in m/s^2).
    tuning : {"noise", "thesis"}
        Which tuning.

    Returns
    -------
    AgriMaRoEKFSettings

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


def agrimaro_missing_stream_notes(run: Run) -> tuple[str, ...]:
    """Notes for the AgriMaRo sensors a run lacks, and what the estimate loses with each.

    Parameters
    ----------
    run : Run
        AgriMaRo run.

    Returns
    -------
    tuple of str
        One ``note: ...`` per missing ``omega`` (wheel 3), ``cam`` (visual odometry, the
        only measurement of the speed over ground: thesis ch. 6.1) and ``steer`` (steering
        encoders) stream; empty when all are there.
    """
    notes = []
    if "omega" not in run.streams:
        notes.append(f"note: run {run.run_id} is an AgriMaRo run without an omega stream: "
                     "wheels 1 and 2 from its wheels stream (vel_l, vel_r), wheel 3 has no "
                     "encoder, so slip_3 is not estimated")
    if "cam" not in run.streams:
        notes.append(f"note: run {run.run_id} has no cam stream (the T265 visual odometry, "
                     "the only measurement of the speed over ground): slip_* rests on the "
                     "process model and the wheel speeds, see std_slip_*; the encoder lag is "
                     "not estimated (the camera speed is its reference)")
    if "steer" not in run.streams:
        notes.append(f"note: run {run.run_id} has no steer stream: the steering angles "
                     "delta_1..3 (and the slip of a steered wheel) rest on the process model")
    return tuple(notes)


def estimate_agrimaro_run(run: Run, *, lag: str = "xcorr", tuning: str = "noise",
                          gate: Gate | None = None, rate_hz: float | None = None,
                          store_covariance: bool = False,
                          settings: AgriMaRoEKFSettings | None = None) -> RunEstimate:
    """States and slip of wheels 1-3 of an AgriMaRo run: the 12-state EKF
    (:func:`~terrain.estimation.agrimaro.estimate_agrimaro`), then the raw rim speeds against
    the EKF velocity moved to each wheel with the EKF steering angles (seed 001 eqs. 7.3-7.5,
    :func:`~terrain.slip.wheel_slip`); ``slip_std`` propagates the EKF's marginal standard
    deviations of the speed, yaw rate and steering angles to first order (one-sigma finite
    differences, correlations ignored; the camera makes the slip observable), plus the noise
    of the raw rim speed itself, which enters the slip unfiltered (ch. 7.2): its
    :func:`~terrain.estimation.prefilter.robust_noise_std` on the filter's grid, where the
    slip is computed (on a simulated AgriMaRo run about 0.035 m/s, 0.08 of slip at 0.45 m/s;
    without it the std was half the error). In the dead band (both the rim speed and the
    wheel's velocity below :data:`~terrain.slip.DEAD_BAND_M_S`) the slip is 0 by the
    thesis's convention (ch. 7.2.1), not an estimate, so ``slip_std`` is NaN there (it was
    0, which claimed certainty: at the start of a simulated GRASS orchard run the physics'
    slip reaches 0.21 there); a note counts those samples. The propagation runs through the
    unclipped SAE ratio, so a slip at the +-1 clip keeps a std (clipped, its finite
    differences were 0 while the estimate was off by up to 1.0 at a spin's reversal); a
    note counts the samples saturated there (:func:`clip_notes`).

    Parameters
    ----------
    run : Run
        AgriMaRo run.
    lag : {"xcorr", "ema", "none"}
        Encoder lag handling (module docstring).
    tuning : {"noise", "thesis"}
        Tuning when ``settings`` is None (:func:`agrimaro_settings`).
    gate : Gate, optional
        Chi-square gating per sensor.
    rate_hz : float, optional
        Filter rate, Hz (default: the IMU rate).
    store_covariance : bool
        Keep the full covariances.
    settings : AgriMaRoEKFSettings, optional
        Explicit tuning.

    Returns
    -------
    RunEstimate

    Raises
    ------
    EstimationError, DataFormatError
        The run lacks a wheel-speed or IMU stream.
    ConfigError
        Unknown tuning or lag mode.
    """
    _check_lag(lag)
    params = get_vehicle("agrimaro")
    settings = settings or agrimaro_settings(run, tuning)
    if lag == "ema":
        settings = with_camera_ema(settings)
    t_om, om = agrimaro_wheel_speeds(run, params)
    lag_est = agrimaro_encoder_lag(run, t_om, om, params) if lag == "xcorr" else None
    offsets = {"omega": lag_est.lag_s} if lag_est is not None and lag_est.applied else {}
    ekf = estimate_agrimaro(run, settings, rate_hz=rate_hz, gate=gate, time_offsets_s=offsets,
                            store_covariance=store_covariance)
    rim = resample(ekf.t_s, t_om - offsets.get("omega", 0.0), om) * params.wheel_radius_m
    names = ["v_bx", "v_by", "yaw_rate"] + [f"delta_{i}" for i in (1, 2, 3)]
    cols = [ekf.state_names.index(n) for n in names]

    def v_long_at(x: np.ndarray) -> np.ndarray:
        return wheel_longitudinal_velocity(x[:, 0], x[:, 1], x[:, 2], params.positions,
                                           x[:, 3:])

    def unclipped(rim_m_s: np.ndarray, v_long_m_s: np.ndarray) -> np.ndarray:
        # |s| <= 2 by construction: saturation 2 clips nothing, so a slip at the +-1 clip
        # keeps its sensitivity (clipped, its finite differences would be 0)
        return sae_slip(rim_m_s, v_long_m_s, dead_band_m_s=DEAD_BAND_M_S, saturation=2.0)

    x = ekf.x[:, cols]
    v_long = v_long_at(x)
    slip = sae_slip(rim, v_long, dead_band_m_s=DEAD_BAND_M_S)    # wheel_slip on these inputs
    base = unclipped(rim, v_long)
    # first-order propagation of the EKF's marginal variances (correlations ignored)
    var = np.zeros_like(slip)
    for j, sd in enumerate(np.sqrt(ekf.P_diag[:, cols]).T):
        xp = x.copy()
        xp[:, j] += sd
        var += (unclipped(rim, v_long_at(xp)) - base) ** 2
    # ... and of the raw rim speed's own noise (it enters the slip unfiltered, ch. 7.2)
    steps = np.diff(ekf.t_s)
    rim_sd = (robust_noise_std(rim, 1.0 / float(np.median(steps))) if steps.size
              else np.zeros(rim.shape[1]))
    var += (unclipped(rim + np.nan_to_num(rim_sd), v_long) - base) ** 2
    # in the dead band the slip is 0 by convention (ch. 7.2.1), not an estimate: no std
    in_band = in_dead_band(rim, v_long, DEAD_BAND_M_S)
    std = np.where(in_band, np.nan, np.sqrt(var))
    notes = (agrimaro_missing_stream_notes(run) + lag_notes(run, lag_est)
             + dead_band_notes(in_band, run.run_id) + clip_notes(base, run.run_id))
    return RunEstimate(run.run_id, "agrimaro", ekf, slip, ("slip_1", "slip_2", "slip_3"),
                       lag_est, {"tuning": settings.name, "lag_mode": lag,
                                 "time_offsets_s": offsets, "dead_band_m_s": DEAD_BAND_M_S},
                       std, notes)


def clip_notes(unclipped_slip: np.ndarray, run_id: str) -> tuple[str, ...]:
    """A note counting the slip samples saturated to +-1 (seed 001 ch. 7.2.1's clip).

    Where the rim speed and the wheel's velocity have opposite signs (a wheel turning
    against its motion, as at a spin's reversal when the wheel speed crosses zero first) the
    SAE ratio reaches up to +-2; the slip reports +-1 there.

    Parameters
    ----------
    unclipped_slip : ndarray, shape (N, k)
        SAE ratio before the clip (:func:`sae_slip` with saturation 2), dimensionless.
    run_id : str
        The run, named in the note.

    Returns
    -------
    tuple of str
        One ``note: run <id>: ...``, or none when no sample is beyond +-1.
    """
    beyond = np.abs(np.asarray(unclipped_slip, dtype=float)) > 1.0
    n = int(np.count_nonzero(beyond))
    if n == 0:
        return ()
    return (f"note: run {run_id}: {n} of {beyond.size} wheel slip samples beyond +-1 (rim "
            f"speed against the wheel's motion, e.g. at a spin's reversal) saturated to +-1 "
            f"(ch. 7.2.1); std_slip from the unclipped ratio",)


def dead_band_notes(in_band: np.ndarray, run_id: str, std: bool = True) -> tuple[str, ...]:
    """A note counting the slip samples set to 0 by the dead band (seed 001 ch. 7.2.1).

    Parameters
    ----------
    in_band : ndarray of bool, shape (N, k)
        Where both the rim speed and the wheel's longitudinal velocity are below
        :data:`~terrain.slip.DEAD_BAND_M_S`.
    run_id : str
        The run, named in the note.
    std : bool
        The estimate has a ``std_slip`` (NaN in the dead band, said in the note).

    Returns
    -------
    tuple of str
        One ``note: run <id>: ...``, or none when no sample is in the dead band.
    """
    n = int(np.count_nonzero(in_band))
    if n == 0:
        return ()
    return (f"note: run {run_id}: {n} of {in_band.size} wheel slip samples in the "
            f"{DEAD_BAND_M_S} m/s dead band (both speeds below it, ch. 7.2.1): slip 0 by "
            f"convention"
            + (", std_slip NaN" if std else ""),)


def estimate_skid_steer_run(run: Run, *, lag: str = "xcorr", gate: Gate | None = None,
                            rate_hz: float | None = None, store_covariance: bool = False,
                            settings: SkidSteerSettings | None = None) -> RunEstimate:
    """States and side slips of a skid-steer run: the 4-state EKF
    (:func:`~terrain.estimation.skid_steer.estimate_skid_steer`), then
    :func:`~terrain.slip.skid_steer_side_slip` (side 1 = left, 2 = right).

    Parameters
    ----------
    run : Run
        Husky or tracked run with a ``wheels`` stream.
    lag : {"xcorr", "ema", "none"}
        ``xcorr`` estimates the wheel-stream lag against the gyro; the others do nothing.
    gate : Gate, optional
        Chi-square gating per sensor.
    rate_hz : float, optional
        Filter rate, Hz (default: the IMU rate).
    store_covariance : bool
        Keep the full covariances.
    settings : SkidSteerSettings, optional
        Explicit tuning (default: the vehicle's track width, default tuning).

    Returns
    -------
    RunEstimate

    Raises
    ------
    EstimationError
        No ``wheels`` stream.
    ConfigError
        Unknown vehicle or lag mode.
    """
    _check_lag(lag)
    params = get_vehicle(run.vehicle)
    settings = settings or SkidSteerSettings(track_m=params.track_m)
    w = run.streams.get("wheels")
    if w is None:
        raise EstimationError(f"run {run.run_id} has no wheels stream")
    lag_est = skid_steer_encoder_lag(run, settings.track_m) if lag == "xcorr" else None
    offsets = {"wheels": lag_est.lag_s} if lag_est is not None and lag_est.applied else {}
    ekf = estimate_skid_steer(run, settings, rate_hz=rate_hz, gate=gate, time_offsets_s=offsets,
                              store_covariance=store_covariance)
    rim = resample(ekf.t_s, w[TIME].to_numpy(float) - offsets.get("wheels", 0.0),
                   w[["vel_l", "vel_r"]].to_numpy(float))
    v_bx, yaw_rate = ekf.state("v_bx"), ekf.state("yaw_rate")
    slip = skid_steer_side_slip(rim, v_bx, yaw_rate, settings.track_m)
    # in the dead band the slip is 0 by convention (ch. 7.2.1): counted, as for the AgriMaRo
    v_long = wheel_longitudinal_velocity(v_bx, np.zeros_like(v_bx), yaw_rate,
                                         skid_steer_contact_lines_m(settings.track_m))
    in_band = in_dead_band(rim, v_long, DEAD_BAND_M_S)
    return RunEstimate(run.run_id, params.name, ekf, slip, ("slip_1", "slip_2"), lag_est,
                       {"tuning": "skid-steer default", "lag_mode": lag,
                        "time_offsets_s": offsets, "dead_band_m_s": DEAD_BAND_M_S},
                       notes=lag_notes(run, lag_est) + dead_band_notes(in_band, run.run_id,
                                                                       std=False))


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
        Keep the full covariance of every step (memory N n^2 floats).
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
    _check_lag(lag)
    vehicle = get_vehicle(run.vehicle).name
    if vehicle == "agrimaro":
        if settings is not None and not isinstance(settings, AgriMaRoEKFSettings):
            raise ConfigError("agrimaro runs need AgriMaRoEKFSettings")
        return estimate_agrimaro_run(run, lag=lag, tuning=tuning, gate=gate, rate_hz=rate_hz,
                                     store_covariance=store_covariance, settings=settings)
    if settings is not None and not isinstance(settings, SkidSteerSettings):
        raise ConfigError(f"{vehicle} runs need SkidSteerSettings")
    return estimate_skid_steer_run(run, lag=lag, gate=gate, rate_hz=rate_hz,
                                   store_covariance=store_covariance, settings=settings)


#: Slip sources of :func:`estimate_skid_steer_slip_run` (``terrain estimate --slip-model``).
SLIP_MODELS = ("ekf", "physics", "learned", "fused")
#: Note of a run whose ``learned`` source fell back to the physics slip (no learned output).
LEARNED_FALLBACK_NOTE = "note: no learned slip model available: falling back to physics"


@dataclass(frozen=True)
class FusionSettings:
    """How the slip models become the EKF's pseudo-measurement.

    Parameters
    ----------
    learned_std_floor : float
        Only for a learned model without a calibrated std (fitted before the calibration, or
        without groups): its std is then the heuristic ``sqrt(floor^2 + (learned -
        physics)^2)`` (ASSUMED 0.01, the largest held-out median error of the first registered
        model on steady straight driving, 0.0072). A calibrated model supplies its own std
        (:meth:`terrain.slip.learned.SlipRegressor.predict_std`, from grouped out-of-fold
        residuals of the training runs).
    min_std : float
        Floor of every pseudo-measurement std, dimensionless (it guards against a vanishing
        std, e.g. the physics std of ~1e-4 on firm ground, where the error of a 2 s window
        mean in a transient is larger). Default 0.003, tuned with the earlier heuristic
        learned std and used by the online observer of the control loop; the batch estimate
        uses :data:`BATCH_FUSION` (1e-5, with a slip drift scaled with the slope of the
        traction curve), ``docs/slip_learning.md``.
    filter : SkidSteerSlipSettings
        Tuning of the slip-augmented EKF.
    error_correlation : float or None
        Correlation of the physics and learned window errors assumed by ``fused``, in
        [-1, 1]: the fused std is then that of the inverse-variance weighted mean,
        ``sqrt(wp^2 sp^2 + wl^2 sl^2 + 2 rho wp wl sp sl)``. None: the smaller of the two stds
        (the most conservative rule, right when the errors are fully correlated).

    Raises
    ------
    ConfigError
        A value that is not a real number (:func:`terrain.errors.config_numbers`;
        ``error_correlation`` may be None), ``min_std`` not finite and > 0,
        ``learned_std_floor`` not finite and >= 0, or ``error_correlation`` outside [-1, 1].
    """

    learned_std_floor: float = 0.01
    min_std: float = 0.003
    filter: SkidSteerSlipSettings = field(default_factory=SkidSteerSlipSettings)
    error_correlation: float | None = None

    def __post_init__(self) -> None:
        config_numbers("FusionSettings", ("error_correlation",),
                       learned_std_floor=self.learned_std_floor, min_std=self.min_std,
                       error_correlation=self.error_correlation)
        if not 0.0 < self.min_std < np.inf:        # a NaN floor made every std NaN
            raise ConfigError(f"FusionSettings.min_std must be a finite std > 0, got "
                              f"{self.min_std}")
        if not 0.0 <= self.learned_std_floor < np.inf:
            raise ConfigError(f"FusionSettings.learned_std_floor must be a finite std >= 0, "
                              f"got {self.learned_std_floor}")
        rho = self.error_correlation
        if rho is not None and not -1.0 <= rho <= 1.0:
            raise ConfigError(f"FusionSettings.error_correlation must be in [-1, 1], got {rho}")


#: Settings of the batch estimate (:func:`estimate_skid_steer_slip_run`, ``terrain estimate``):
#: pseudo-measurement floor 1e-5 (a guard against a zero std only) and the slip drift density
#: ``1e-11 + 0.015 std_I^2 + 1.0 std_T^2`` /s, with ``std_I`` the physics slip std from the
#: current noise alone (``physics_current`` of
#: :func:`features.slip_outputs.slip_model_outputs`: the traction noise over the slope of the
#: terrain's curve, through ``slip_psd_rel``) and ``std_T`` the slip change inside the window
#: (``physics_transient``: traction that changed beyond the current noise, through
#: ``slip_psd_transient``): a steady drive leaves the slip where it is, so the filter averages
#: many windows; a start or a spin lets it follow. Tuned on seeds 200-211 (``straight_accel``,
#: 12 runs per terrain, neither the learned model's training seeds nor the evaluation seeds)
#: after the physics slip's normal load was corrected for the pitch noise
#: (:func:`terrain.slip.physics.normal_load_factor`); evaluated once on fresh seeds 500-511
#: (``docs/slip_learning.md`` section 5; before: ``1e-10 + 0.03 std_I^2``, tuned on two seeds,
#: conservative on the fresh seeds), and later on blocks of 48 fresh seeds: 1000-1047 and
#: 2000-2047 pooled mean NEES 2.01-2.20 on ASPHALT, SANDY_LOAM, ICE and GRASS (inside),
#: SNOW 1.63 / 1.66 until the run's pitch prior (1.80); 3000-3047 SNOW 1.97 (inside), the
#: others 2.24-2.34 (upper bounds 2.25-2.26). ``slip_psd_rel`` then 0.01 -> 0.015, chosen on
#: those 144 seeds pooled (4 of 5 terrains inside, against 1), and checked once on fresh
#: seeds 4000-4047: all five terrains inside (1.84-2.12); rechecked on the simulator of
#: 2026-11-26: 4000-4047 still all five inside, the 144 seeds would now pick 0.02 (GRASS 2.19
#: at 0.015), a fresh block 5000-5047 keeps 0.015 (4 inside for both, triplets 63 vs 58;
#: ``docs/slip_learning.md`` section 5). The fused std assumes a correlation of
#: 0.1 between the physics and learned window errors (their normalised errors' correlation pooled
#: over the five terrains of seeds 200, 201: 0.085; per run -0.03 to 0.13, GRASS 0.34-0.51).
BATCH_FUSION = FusionSettings(min_std=1e-5, filter=SkidSteerSlipSettings(
    slip_psd=1e-11, slip_psd_rel=0.015, slip_psd_transient=1.0), error_correlation=0.1)


def pseudo_measurement(outputs: dict[str, tuple[np.ndarray, np.ndarray, np.ndarray]],
                       source: str, settings: FusionSettings = FusionSettings()
                       ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Slip pseudo-measurement and its std from the slip models (:class:`FusionSettings`).

    ``fused``: inverse-variance weighted mean of physics and learned; its std is that of the
    weighted mean for errors of correlation ``settings.error_correlation``, or, when that is
    None, the better of the two stds (the learned model takes the physics slip as a feature,
    so their errors need not be independent). A window side where one model's slip or std
    is NaN (the physics std where the current's spread in the window is unknown) takes the
    other model's slip and std alone.

    Parameters
    ----------
    outputs : dict
        :func:`features.slip_outputs.slip_model_outputs`.
    source : {"physics", "learned", "fused"}
        Which model (``fused`` without a learned model is ``physics``).
    settings : FusionSettings
        Std floors.

    Returns
    -------
    t_s : ndarray, shape (k,)
        Window centres, s (the ``t_s`` of ``outputs``: the time a window mean describes).
    slip : ndarray, shape (k, 2)
        Sides 1, 2.
    std : ndarray, shape (k, 2)

    Raises
    ------
    ConfigError
        Unknown source, ``outputs`` without its ``physics`` entry, or ``learned`` without a
        learned model.
    """
    if source not in ("physics", "learned", "fused"):
        raise ConfigError(f"unknown slip source {source!r}; valid: physics, learned, fused")
    if "physics" not in outputs:     # every source reads it (a bare KeyError before)
        raise ConfigError(f"the slip model outputs have no 'physics' entry (got "
                          f"{sorted(outputs) or 'none'}): every slip source needs the physics "
                          "window outputs")
    t, sp, vp = outputs["physics"]
    vp = np.maximum(vp, settings.min_std)
    if source == "physics" or (source == "fused" and "learned" not in outputs):
        return t, sp, vp
    if "learned" not in outputs:
        raise ConfigError("the learned slip model is not available")
    _, sl, cal = outputs["learned"]
    heuristic = np.hypot(settings.learned_std_floor, sl - sp)   # a model without calibration
    vl = np.maximum(np.where(np.isfinite(cal), cal, heuristic), settings.min_std)
    if source == "learned":
        return t, sl, vl
    wp, wl = vp ** -2, vl ** -2
    mean = (wp * sp + wl * sl) / (wp + wl)
    rho = settings.error_correlation
    if rho is None:
        std = np.minimum(vp, vl)
    else:
        ap, al = wp / (wp + wl), wl / (wp + wl)
        if rho >= 0.0:
            var = (ap * vp) ** 2 + (al * vl) ** 2 + 2.0 * rho * ap * al * vp * vl
        else:
            # the same variance as a square plus a part >= 0: a^2 + b^2 - 2 |rho| a b
            # cancels where a ~ b (rho -1, two nearly equal stds) and rounding made it < 0
            a, b = ap * vp, al * vl
            var = (a - b) ** 2 + 2.0 * (1.0 + rho) * a * b
        std = np.maximum(np.sqrt(var), settings.min_std)
    # a window side that one model cannot judge (its slip or std NaN: the physics std where
    # the current's spread in the window is unknown) takes the other model's alone; the
    # NaN of the weighted mean dropped the learned slip there too
    physics_known = np.isfinite(sp) & np.isfinite(vp)
    learned_known = np.isfinite(sl) & np.isfinite(vl)
    mean = np.where(physics_known, np.where(learned_known, mean, sp), sl)
    std = np.where(physics_known, np.where(learned_known, std, vp), vl)
    return t, mean, std


def estimate_skid_steer_slip_run(run: Run, slip_model: str = "fused", *,
                                 outputs: dict[str, tuple[np.ndarray, np.ndarray, np.ndarray]]
                                 | None = None, missing: str | None = None,
                                 lag: str = "xcorr",
                                 gate: Gate | None = None, rate_hz: float | None = None,
                                 settings: FusionSettings = BATCH_FUSION) -> RunEstimate:
    """States and side slips with standard deviations of a skid-steer run: the slip-augmented
    EKF of :mod:`terrain.estimation.skid_steer_slip` with the slip model as pseudo-measurement
    and the accelerometer.

    Parameters
    ----------
    run : Run
        Husky or tracked run (``wheels``; ``imu`` and currents for the slip models).
    slip_model : {"ekf", "physics", "learned", "fused"}
        Pseudo-measurement source; ``ekf``: none, the plain skid-steer EKF
        (:func:`estimate_skid_steer_run`: ``slip_*`` its turning part only, no std).
    outputs : dict, optional
        Window outputs of the slip models
        (:func:`features.slip_outputs.slip_model_outputs`: ``physics``, ``physics_current``
        (its std scales the slip drift when ``settings.filter.slip_psd_rel > 0``; without it
        the pseudo-measurement std does), ``physics_interval`` (the physics slip's interval,
        for windows at full slip) and, with a learned model, ``learned``); None when they
        could not be computed: then the plain EKF answers, as for ``ekf`` (with no
        pseudo-measurement the slip-augmented EKF has only the accelerometer to tie the
        speed to, drifts and calls the drift certain), and a note says why.
    missing : str, optional
        Why ``outputs`` is None, in words (:func:`features.slip_outputs.missing_slip_inputs`),
        for the note that says no slip model supplied the common slip.
    lag : {"xcorr", "ema", "none"}
        ``xcorr`` estimates the wheel-stream lag against the gyro.
    gate : Gate, optional
        Chi-square gating per sensor.
    rate_hz : float, optional
        Filter rate, Hz (default: the IMU rate, else the wheel rate, read off the stream's
        clock by :func:`terrain.estimation.runner.clock_rate_hz`).
    settings : FusionSettings
        Std floors and EKF tuning (default :data:`BATCH_FUSION`).

    Returns
    -------
    RunEstimate
        ``slip`` and ``slip_std`` from the EKF states ``slip_1, slip_2``, in [-1, 1] (the
        model's ``state_bounds``; the plain EKF's turning slip and no std without a slip
        model); ``notes`` say which source supplied the unobservable common slip (and any
        fallback). With the ``physics`` or ``fused`` source a window-side whose physics slip
        is full slip (+-1: the current asks for at least the curve's maximum traction, which
        bounds the slip without measuring it) enters as the centre of its physics interval
        (``physics_interval`` of the outputs) with the physics std, not as +-1; without
        ``physics_interval`` it is skipped (a run with every window-side at full slip then
        gets the plain EKF's answer). A note and ``meta["pseudo_full_slip"]`` (of
        ``meta["pseudo_window_sides"]``; ``meta["pseudo_full_slip_use"]``: ``"interval
        centre"``, ``"skipped"`` or ``"none"``) count them; a window-side whose physics slip
        has no finite std (an unknown current spread inside the window) is skipped, counted
        in ``meta["pseudo_unknown_std"]`` and a note. The forward speed is held within
        what the recent rim speeds allow (``settings.filter.speed_bound_braking_slip``,
        :func:`terrain.estimation.skid_steer_slip.speed_bounds_m_s`); the steps where the
        estimate was projected back are ``meta["speed_bound_active_steps"]`` and a note.

    Raises
    ------
    EstimationError
        No ``wheels`` stream.
    TimeStepError
        A stream's timestamps not finite and strictly increasing (run and stream named), or
        the wheels and the IMU not overlapping in time (run and spans named).
    ConfigError
        Unknown slip model, lag mode or vehicle; ``outputs`` without ``physics``
        (:func:`pseudo_measurement`); ``rate_hz`` outside ``[MIN_RATE_HZ, MAX_RATE_HZ]``
        (:func:`~terrain.estimation.runner.check_rate_hz`).
    """
    from terrain.estimation.runner import (SensorSamples, make_grid, stream_overlap_s,
                                           stream_samples)
    from terrain.estimation.skid_steer_slip import run_with_pseudo_slip

    if slip_model not in SLIP_MODELS:
        raise ConfigError(f"unknown slip model {slip_model!r}; valid: {', '.join(SLIP_MODELS)}")
    _check_lag(lag)
    if slip_model == "ekf" or outputs is None:
        # without a pseudo-measurement the slip-augmented EKF has only the accelerometer to
        # tie the speed to: white accelerometer noise and no bias state make it drift and
        # call the drift certain (a 120 s run: slip 0.77 with std 0.003 against a true 0 to
        # 0.17, NIS 7.95 on 3.1 dof), so the plain EKF answers, and says what it can
        est = estimate_skid_steer_run(run, lag=lag, gate=gate, rate_hz=rate_hz)
        why = "--slip-model ekf" if slip_model == "ekf" else "none could be used"
        est.notes = ("note: longitudinal slip common to both sides (slip_1, slip_2) is not "
                     f"observable from wheel speeds + IMU and no slip model is used ({why}): "
                     "slip_* is the turning part only, std_slip_* not available",) + est.notes
        if "imu" not in run.streams:    # nor the turning part: nothing but the wheels
            est.notes += (f"note: run {run.run_id} has no IMU stream: no gyro observes its "
                          "yaw rate, so slip_* (the turning part too) and gyro_bias are the "
                          "filter's prediction from the wheel speeds alone, not estimates",)
        if slip_model != "ekf":
            est.notes += (f"{slip_model} slip model not used for run {run.run_id}: "
                          f"{missing or 'its window outputs were not given'}",)
        est.meta["slip_model"] = "ekf"
        return est
    params = get_vehicle(run.vehicle)
    fs = replace(settings.filter, track_m=params.track_m)
    w = run.streams.get("wheels")
    if w is None:
        raise EstimationError(f"run {run.run_id} has no wheels stream")
    lag_est = skid_steer_encoder_lag(run, fs.track_m) if lag == "xcorr" else None
    applied = lag_est is not None and lag_est.applied
    off = lag_est.lag_s if applied else 0.0
    samples = {"wheels": stream_samples(run.run_id, "wheels", w[TIME].to_numpy(float) - off,
                                        w[["vel_l", "vel_r"]].to_numpy(float))}
    spans = [samples["wheels"].t_s]
    imu = run.streams.get("imu")
    if imu is not None:
        t_imu = imu[TIME].to_numpy(float)
        samples["gyro"] = stream_samples(run.run_id, "imu", t_imu, imu[["wz"]].to_numpy(float))
        acc = imu[["ax", "az"]].to_numpy(float)
        samples["accel"] = SensorSamples(t_imu, acc)
        spans.append(t_imu)
        if len(imu) > 50:        # vibration sets the accelerometer noise: measure it on the run
            noise = np.nanmax(robust_noise_std(acc, float(1.0 / np.median(np.diff(t_imu)))))
            if np.isfinite(noise) and noise > 0:
                fs = replace(fs, accel_std_m_s2=float(noise))
    rate = check_rate_hz(rate_hz)
    # the estimators' one default rate: the IMU's median step, snapped within the clock's
    # rounding (clock_rate_hz; 1 / median read 100.0000000524 Hz at 1e5 s)
    rate = clock_rate_hz(spans[-1]) if rate is None else rate
    grid = make_grid(*stream_overlap_s(run.run_id, dict(zip(("wheels", "imu"), spans)),
                                       f", after the wheels' lag of {off:.6g} s was subtracted"
                                       if off else ""), rate)
    notes: list[str] = list(lag_notes(run, lag_est))
    source = slip_model
    if slip_model == "learned" and outputs is not None and "learned" not in outputs:
        notes.append(LEARNED_FALLBACK_NOTE)
        source = "physics"
    if source == "fused" and "learned" not in outputs:
        source = "fused (physics only: no learned model)"
        pm = pseudo_measurement(outputs, "physics", settings)
    else:
        pm = pseudo_measurement(outputs, source, settings)
    full = np.zeros(pm[1].shape, dtype=bool)
    full_use = "none"
    if source != "learned":
        # physics slip at full slip: the current asks for at least the most traction the
        # terrain's curve gives, which a curve rising up to full slip (SNOW, SANDY_LOAM,
        # GRASS) reaches only there: it bounds the slip (terrain.slip.physics, module
        # docstring) and, taken as a measurement of +-1 (std 1e-5 where the interval
        # collapsed), pinned the states at the bound and past it
        t_p, s_p, sd_p = outputs["physics"]
        full = np.abs(np.nan_to_num(s_p)) >= 1.0
        if full.any() and "physics_interval" in outputs:
            lo, up = outputs["physics_interval"][1:]
            centred = dict(outputs, physics=(t_p, np.where(full, 0.5 * (lo + up), s_p), sd_p))
            pm = pseudo_measurement(centred, "physics" if source.startswith("fused (")
                                    else source, settings)
            full_use = "interval centre"
            notes.append(
                f"note: physics slip at full slip (+-1) on {int(full.sum())} of {full.size} "
                "window-sides (the current asks for at least the most traction the "
                f"{run.terrain} curve gives: the slip is bounded, not measured); their "
                "pseudo-measurement is the centre of the physics interval with its std")
        elif full.all():
            est = estimate_skid_steer_slip_run(
                run, slip_model, outputs=None, lag=lag, gate=gate, rate_hz=rate_hz,
                settings=settings, missing=(
                    f"the physics slip is full slip (+-1) on every window-side ({full.size}):"
                    f" the current asks for at least the most traction the {run.terrain} "
                    "curve gives, which bounds the slip without measuring it"))
            # every window-side skipped: counted as when only some are
            est.meta.update(pseudo_full_slip=int(full.sum()), pseudo_full_slip_use="skipped",
                            pseudo_window_sides=int(full.size))
            return est
        elif full.any():
            pm = (pm[0], np.where(full, np.nan, pm[1]), pm[2])
            full_use = "skipped"
            notes.append(
                f"note: physics slip at full slip (+-1) on {int(full.sum())} of {full.size} "
                "window-sides (the current asks for at least the most traction the "
                f"{run.terrain} curve gives: the slip is bounded, not measured); their "
                "pseudo-measurement is skipped (no physics_interval in the outputs)")
    unknown = np.zeros(full.shape, dtype=bool)
    if source != "learned":
        # a physics slip without a std (its current spread inside the window unknown:
        # terrain.slip.physics.within_window_current_std) is skipped by the filter, and said
        s_p, sd_p = outputs["physics"][1:]
        unknown = np.isfinite(s_p) & ~np.isfinite(sd_p)
        if unknown.any():
            notes.append(
                f"note: physics slip without a std on {int(unknown.sum())} of {unknown.size} "
                "window-sides (its uncertainty is unknown, e.g. the current spread inside the "
                "window is NaN: not taken as steady); their pseudo-measurement is skipped")
    # drift scaled with the slope of the traction curve: the physics std from current noise
    drift = (outputs["physics_current"][2] if fs.slip_psd_rel > 0 and pm[0] is not None
             and "physics_current" in outputs else None)
    # and with the slip change inside each window (starts, spins, steps)
    change = (outputs["physics_transient"][2] if fs.slip_psd_transient > 0
              and pm[0] is not None and "physics_transient" in outputs else None)
    ekf = run_with_pseudo_slip(grid, samples, fs, *pm, gate=gate, drift_std=drift,
                               transient_std=change)
    names = ("slip_1", "slip_2")
    idx = [ekf.state_names.index(n) for n in names]
    notes.insert(0, "note: longitudinal slip common to both sides (slip_1, slip_2) is not "
                    "observable from wheel speeds + IMU; supplied by the "
                    f"{source} slip model (pseudo-measurement)")
    held = int(ekf.meta.get("step_bounds_active", 0))
    if held:
        # the speed and the slips ran off along the direction the wheels cannot see
        notes.append(
            f"note: forward speed projected back into the range the rim speeds allow "
            f"(braking slip down to {fs.speed_bound_braking_slip:+.2f}, "
            "terrain.estimation.skid_steer_slip.speed_bounds_m_s) on "
            f"{held} of {grid.size} steps ({100.0 * held / grid.size:.1f} %) of run "
            f"{run.run_id}; the slips moved with it")
    ekf.meta.update(model="skid-steer-slip-8", track_m=fs.track_m,
                    time_offsets_s={"wheels": off} if applied else {})
    return RunEstimate(run.run_id, params.name, ekf, ekf.x[:, idx], names, lag_est,
                       {"tuning": "skid-steer-slip default", "lag_mode": lag,
                        "slip_model": source, "dead_band_m_s": DEAD_BAND_M_S,
                        "pseudo_full_slip": int(full.sum()),
                        "speed_bound_active_steps": held,
                        "pseudo_full_slip_use": full_use,
                        "pseudo_unknown_std": int(unknown.sum()),
                        "pseudo_window_sides": int(full.size)},
                       np.sqrt(ekf.P_diag[:, idx]), tuple(notes))
