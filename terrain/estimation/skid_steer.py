"""Skid-steer EKF for IMU + wheel-speed data (Clearpath Husky, tracked vehicles).

State (4)::

    x = [v_bx, yaw_rate, b_g, ln(chi)]
         m/s   rad/s     rad/s 1

with ``chi`` the ICR expansion factor (Mandow et al. 2007, see
:mod:`terrain.vehicles.skid_steer`): the two sides' contact lines act as if they were
``chi B`` apart, so with rolling contact

    vel_l = v_bx - chi B yaw_rate / 2,   vel_r = v_bx + chi B yaw_rate / 2     (wheels)
    wz    = yaw_rate + b_g                                                       (gyro)

which is seed ``000_f24201ff985633bf.txt`` eq. 3 with ``eta_L = eta_R = 1/chi`` for the
turning part and no longitudinal slip. Every state is a random walk (process noise densities
in :class:`SkidSteerSettings`). ``chi`` is estimated as its logarithm: it stays positive, its
uncertainty is relative (the prior spans a factor of e per standard deviation, enough for
the chi of 1.1 on asphalt to about 10 on snow or ice without a retune), and the filter cannot
collapse to ``chi = 0``, where the wheels would stop constraining the yaw rate and the gyro
bias would become unobservable (a failure of the linear ``chi`` parametrisation seen on
simulated ice). The gyro bias is observable whenever the vehicle drives
straight or stands still (``vel_r = vel_l`` forces ``yaw_rate = 0``), ``chi`` whenever it
turns; while driving straight its variance grows and it is re-learnt at the next turn.

Limits (stated): with only wheel speeds and a gyro, the forward speed is the mean wheel speed
(longitudinal slip common to both sides is not observable without an external velocity
reference); the state ``chi`` absorbs every effect that scales the turning rate (lateral
scrub, the side-slip of seed 000 during turns).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field, replace
from types import MappingProxyType
from typing import TYPE_CHECKING, Mapping

import numpy as np
import pandas as pd

from terrain.errors import (ConfigError, DataFormatError, NonFiniteInputError, NonNumericError,
                            ShapeError, config_numbers, config_positive, holds_booleans)
from terrain.estimation.ekf import Gate
from terrain.estimation.equations.skid_steer import (SkidSteerEquationParams, observation_into,
                                                     transition_into)
from terrain.estimation.model import KernelModel, diagonal_process_noise
from terrain.estimation.result import EKFResult
from terrain.estimation.runner import (SensorSamples, check_rate_hz, check_time_offsets,
                                       clock_rate_hz, make_grid, run_filter, sensor_groups,
                                       stream_overlap_s, stream_samples)
from terrain.run import TIME, Run
from terrain.vehicles import get_vehicle
from terrain.vehicles.icr import chi_from_truth  # noqa: F401  (public here too)
from terrain.vehicles.skid_steer import HUSKY, HuskyParams, TrackedParams

if TYPE_CHECKING:
    from terrain.estimation.fast import FastKernel

STATE_NAMES: tuple[str, ...] = ("v_bx", "yaw_rate", "gyro_bias", "log_icr_chi")
MEASUREMENT_NAMES: tuple[str, ...] = ("vel_l", "vel_r", "wz")
SENSOR_ROWS: Mapping[str, tuple[int, ...]] = MappingProxyType({"wheels": (0, 1), "gyro": (2,)})


@dataclass(frozen=True)
class SkidSteerSettings:
    """Parameters and tuning of the skid-steer EKF.

    Parameters
    ----------
    track_m : float
        Geometric track width B, m (Husky 0.5708 m).
    wheel_std_m_s : float
        Noise of a side's wheel speed, m/s (quantisation 0.0079 m/s on the Husky plus
        terrain-induced speed ripple).
    gyro_std_rad_s : float
        Gyro z noise, rad/s.
    accel_psd : float
        Density of the forward acceleration driving ``v_bx``, (m/s^2)^2 s.
    yaw_accel_psd : float
        Density of the yaw acceleration, (rad/s^2)^2 s.
    bias_psd : float
        Gyro bias drift density, (rad/s)^2 / s.
    log_chi_psd : float
        Drift density of ``ln(chi)`` (terrain changes), 1/s.
    chi0 : float
        Prior median of ``chi`` (1 = ideal differential drive).
    log_chi0_std : float
        Prior standard deviation of ``ln(chi)``.
    bias0_std : float
        Prior standard deviation of the gyro bias, rad/s.
    v0_std, yaw_rate0_std : float
        Prior standard deviations of the speed (m/s) and yaw rate (rad/s).
    chi_min_yaw_rate_rad_s : float
        ``chi`` is corrected only while the estimated yaw rate is at least this in
        magnitude (rad/s; exactly at it: corrected): below it the wheel rows still use
        ``chi`` but their Jacobian column for ``ln(chi)`` is
        zero (``chi`` is a *consider* parameter there). Without this, a gyro bias seen
        while driving straight can be explained either by a yaw rate (pulling ``chi``
        towards 0) or by the bias; the filter then slowly drives ``chi`` down and learns
        the bias late.

    Raises
    ------
    ConfigError
        A field not a real number (text, a boolean, None), a standard deviation,
        ``track_m`` or ``chi0`` not > 0, or a density negative or not finite.
    """

    track_m: float = HUSKY.track_m
    wheel_std_m_s: float = 0.03
    gyro_std_rad_s: float = 0.01
    accel_psd: float = 0.1
    yaw_accel_psd: float = 0.1
    bias_psd: float = 1e-8
    log_chi_psd: float = 2e-3
    chi0: float = 1.5
    log_chi0_std: float = 1.0
    bias0_std: float = 0.01
    v0_std: float = 0.3
    yaw_rate0_std: float = 0.3
    chi_min_yaw_rate_rad_s: float = 0.05

    def __post_init__(self) -> None:
        # text passed float() below and was kept as text; True was 1
        config_numbers("SkidSteerSettings", **vars(self))
        for name in ("track_m", "wheel_std_m_s", "gyro_std_rad_s", "log_chi0_std", "bias0_std",
                     "v0_std", "yaw_rate0_std", "chi0"):
            v = float(getattr(self, name))
            if not (np.isfinite(v) and v > 0):
                raise ConfigError(f"{name} must be > 0 and finite, got {v}")
        for name in ("accel_psd", "yaw_accel_psd", "bias_psd", "log_chi_psd",
                     "chi_min_yaw_rate_rad_s"):
            v = float(getattr(self, name))
            if not (np.isfinite(v) and v >= 0):
                raise ConfigError(f"{name} must be >= 0 and finite, got {v}")


@dataclass(frozen=True)
class SkidSteerModel(KernelModel):
    """Random-walk process model with the ICR wheel model (see the module docstring); its
    equations are :mod:`terrain.estimation.equations.skid_steer`.

    Parameters
    ----------
    settings : SkidSteerSettings
        Geometry and tuning.
    wheel_r_scale : float
        Multiplies the wheel-speed variance (e.g. the up-sampling factor when the wheel
        stream has been interpolated onto a faster clock, so that the correlated repeats do
        not count as independent measurements), dimensionless, finite and > 0.

    Attributes
    ----------
    state_names : tuple of str
        :data:`STATE_NAMES` (4).
    measurement_names : tuple of str
        :data:`MEASUREMENT_NAMES` (3).

    Raises
    ------
    ConfigError
        ``wheel_r_scale`` not a finite real number > 0 (text, a boolean).
    """

    settings: SkidSteerSettings = field(default_factory=SkidSteerSettings)
    wheel_r_scale: float = 1.0
    state_names: tuple[str, ...] = field(default=STATE_NAMES, init=False)
    measurement_names: tuple[str, ...] = field(default=MEASUREMENT_NAMES, init=False)
    transition_kernel = staticmethod(transition_into)
    observation_kernel = staticmethod(observation_into)

    def __post_init__(self) -> None:
        # (the text "2" was a variance 2 x, True 1 x; 0, negative or NaN failed later
        # in run_filter as an R that is not a covariance, without naming the field)
        config_positive("SkidSteerModel", wheel_r_scale=self.wheel_r_scale)
        super().__post_init__()

    @property
    def sensor_rows(self) -> Mapping[str, tuple[int, ...]]:
        """Sensor -> measurement rows."""
        return SENSOR_ROWS

    @property
    def equation_params(self) -> SkidSteerEquationParams:
        """Constants of the model's equations (:mod:`terrain.estimation.equations.skid_steer`)."""
        s = self.settings
        return SkidSteerEquationParams(track_m=float(s.track_m),
                                       chi_min_yaw_rate_rad_s=float(s.chi_min_yaw_rate_rad_s))

    def Q(self, dt: float) -> np.ndarray:
        """``diag(accel_psd, yaw_accel_psd, bias_psd, log_chi_psd) dt``.

        Parameters
        ----------
        dt : float
            Step, s (> 0).

        Returns
        -------
        ndarray, shape (4, 4)
        """
        s = self.settings
        return diagonal_process_noise((s.accel_psd, s.yaw_accel_psd, s.bias_psd,
                                       s.log_chi_psd), "second", dt)

    @property
    def R_diag(self) -> np.ndarray:
        """``[s_w^2 k, s_w^2 k, s_g^2]`` with ``k = wheel_r_scale``, shape (3,)."""
        s = self.settings
        w2 = s.wheel_std_m_s ** 2 * float(self.wheel_r_scale)
        return np.array([w2, w2, s.gyro_std_rad_s ** 2])

    @property
    def x0(self) -> np.ndarray:
        """``[0, 0, 0, ln(chi0)]``, shape (4,)."""
        return np.array([0.0, 0.0, 0.0, math.log(self.settings.chi0)])

    @property
    def P0(self) -> np.ndarray:
        """Prior covariance, shape (4, 4)."""
        s = self.settings
        return np.diag([s.v0_std ** 2, s.yaw_rate0_std ** 2, s.bias0_std ** 2,
                        s.log_chi0_std ** 2])

    def fast_kernel(self) -> FastKernel | None:
        """This model's kernels for the compiled loop of :mod:`terrain.estimation.fast` (the
        same functions :meth:`transition` and :meth:`observation` call, with the ``Q`` of
        :meth:`Q`); None for subclasses, which may change them.

        Returns
        -------
        FastKernel or None
        """
        if type(self) is not SkidSteerModel:
            return None
        s = self.settings
        return self.kernel_for_fast_loop((s.accel_psd, s.yaw_accel_psd, s.bias_psd,
                                          s.log_chi_psd), "second")


def estimate_skid_steer(run: Run, settings: SkidSteerSettings | None = None, *,
                        rate_hz: float | None = None, gate: Gate | None = None,
                        time_offsets_s: Mapping[str, float] | None = None,
                        store_covariance: bool = False) -> EKFResult:
    """Run the skid-steer EKF on the native streams of a run.

    Parameters
    ----------
    run : Run
        With a ``wheels`` stream (``vel_l``, ``vel_r``, m/s) and normally an ``imu`` stream
        (``wz``, rad/s). Without IMU the filter runs on the wheels alone (``chi`` and the
        bias then stay at their prior: the wheels observe ``chi yaw_rate`` only, so ``chi``
        is a consider parameter at every yaw rate; so too with an IMU stream whose ``wz``
        holds no finite value). Its ``vehicle`` must be a skid-steer (``husky``,
        ``tracked``).
    settings : SkidSteerSettings, optional
        Geometry and tuning; None (default): the defaults with the track of the run's
        vehicle (:func:`terrain.vehicles.get_vehicle`: 0.5708 m for the Husky, 0.393 m for
        the tracked vehicle), the geometry the simulator drives that vehicle with.
    rate_hz : float, optional
        Filter rate, Hz (default: the IMU rate, else the wheel rate). The grid spans the
        overlap of the streams used.
    gate : Gate, optional
        Per-sensor chi-square gating.
    time_offsets_s : Mapping[str, float], optional
        Per-sensor latency (``wheels``, ``gyro``) subtracted from its timestamps, s.
    store_covariance : bool
        Keep the full covariance of every step (memory N n^2 floats).

    Returns
    -------
    EKFResult

    Raises
    ------
    DataFormatError
        No ``wheels`` stream, a stream it reads of fewer than 2 samples, or one without the
        columns it reads (:class:`~terrain.errors.MissingColumnError`); run and stream
        named.
    TimeStepError
        A stream's timestamps not finite and strictly increasing (run, stream and the first
        such sample named), or streams that do not overlap in time (run and spans named).
    ConfigError
        ``rate_hz`` outside ``[MIN_RATE_HZ, MAX_RATE_HZ]`` (:func:`~terrain.estimation.runner.
        check_rate_hz`), a key of ``time_offsets_s`` other than ``wheels`` and ``gyro``,
        or a latency that is not a finite real number (a boolean, text, None, NaN, inf;
        :func:`~terrain.estimation.runner.check_time_offsets`); a run whose vehicle is not
        a skid-steer (``agrimaro``: its ``wheels`` stream holds wheels 1 and 2 of a swerve
        drive, not two sides) or unknown.
    """
    # (the Husky's track served every run: a tracked run's chi read 1.03 for a true 1.44)
    track_m = skid_steer_track_m(run)
    settings = settings if settings is not None else SkidSteerSettings(track_m=track_m)
    if "wheels" not in run.streams:
        raise DataFormatError("a skid-steer run needs a wheels stream", run.source)
    off = check_time_offsets(time_offsets_s, SENSOR_ROWS)
    w = run.require_columns("wheels", ("vel_l", "vel_r"))
    samples = {"wheels": stream_samples(run.run_id, "wheels",
                                        w[TIME].to_numpy(float) - off.get("wheels", 0.0),
                                        w[["vel_l", "vel_r"]].to_numpy(float))}
    spans = [samples["wheels"].t_s]
    if "imu" in run.streams:
        imu = run.require_columns("imu", ("wz",))
        samples["gyro"] = stream_samples(run.run_id, "imu",
                                         imu[TIME].to_numpy(float) - off.get("gyro", 0.0),
                                         imu[["wz"]].to_numpy(float))
        spans.append(samples["gyro"].t_s)
    for stream, span in zip(("wheels", "imu"), spans):   # the grid spans them all
        if span.size < 2:
            raise DataFormatError(f"run {run.run_id}: stream {stream!r} has {span.size} "
                                  f"sample{'' if span.size == 1 else 's'}; the filter needs 2 "
                                  "or more of each stream it reads", run.source)
    fast = spans[-1]
    rate = check_rate_hz(rate_hz)
    rate = clock_rate_hz(fast) if rate is None else rate
    t0, t1 = stream_overlap_s(run.run_id, dict(zip(("wheels", "imu"), spans)),
                              f", after time_offsets_s {off}")
    settings = _without_gyro(settings, samples["gyro"].values if "gyro" in samples else None)
    result = run_filter(SkidSteerModel(settings), make_grid(t0, t1, rate), samples, gate=gate,
                        store_covariance=store_covariance)
    result.meta.update(model="skid-steer-4", track_m=settings.track_m,
                       time_offsets_s=off)
    return result


def skid_steer_track_m(run: Run) -> float:
    """Track width of the skid-steer vehicle that drove ``run``.

    Parameters
    ----------
    run : Run
        Its ``vehicle`` names the vehicle (:func:`terrain.vehicles.get_vehicle`).

    Returns
    -------
    float
        Geometric track width B, m (``track_m`` of the vehicle's parameters).

    Raises
    ------
    ConfigError
        An unknown vehicle, or one that is not a skid-steer (``agrimaro``).
    """
    params = get_vehicle(run.vehicle)
    if not isinstance(params, (HuskyParams, TrackedParams)):
        raise ConfigError(f"run {run.run_id}: vehicle {run.vehicle!r} is not a skid-steer "
                          "vehicle (husky, tracked), whose left and right sides the skid-steer "
                          "filter reads (the AgriMaRo's filter: estimate_agrimaro)")
    return float(params.track_m)


def wheel_r_scale(rate_hz: float, wheel_rate_hz: float | None) -> float:
    """Wheel-variance inflation of a wheel stream interpolated onto a faster clock.

    ``max(1, rate_hz / wheel_rate_hz)``: each native wheel sample is repeated about that many
    times on the grid, so its variance is multiplied by it to count its information once.

    Parameters
    ----------
    rate_hz : float
        Rate of the grid the wheel samples are on, Hz.
    wheel_rate_hz : float or None
        Native wheel rate, Hz, finite and > 0; None: unknown (or the grid rate), no
        inflation.

    Returns
    -------
    float
        The factor, >= 1, dimensionless.

    Raises
    ------
    ConfigError
        ``wheel_rate_hz`` not None and not a finite number > 0: NaN, 0, negative and inf were
        taken as "no inflation" before; a run whose wheel rate is unknown passes None.
    """
    if wheel_rate_hz is None:
        return 1.0
    config_numbers("skid-steer filter", wheel_rate_hz=wheel_rate_hz)
    if not (math.isfinite(wheel_rate_hz) and wheel_rate_hz > 0):
        raise ConfigError(f"wheel_rate_hz must be a finite number of Hz > 0 (None when the "
                          f"native wheel rate is unknown), got {wheel_rate_hz}")
    return max(1.0, float(rate_hz) / float(wheel_rate_hz))


def _without_gyro(settings: SkidSteerSettings, gyro_rad_s) -> SkidSteerSettings:
    """``settings``, with ``chi`` a consider parameter at every yaw rate where the gyro
    (``None``: no IMU stream) holds no finite value: the wheels observe ``chi yaw_rate``
    only, and the linearised update moved ln(chi) off its prior with a shrinking variance
    (0.405 -> -0.33 at variance 0.02 on a steady turn)."""
    if gyro_rad_s is None or not np.isfinite(gyro_rad_s).any():
        return replace(settings, chi_min_yaw_rate_rad_s=float(np.finfo(float).max))
    return settings


def skid_steer_on_frame(frame: pd.DataFrame, settings: SkidSteerSettings = SkidSteerSettings(),
                        *, wheel_rate_hz: float | None = None, gate: Gate | None = None
                        ) -> EKFResult:
    """Run the skid-steer EKF on an aligned frame (one clock, :mod:`terrain.io.align`).

    Every grid row is a sample of both sensors; NaN rows (gaps) are skipped and counted.
    Because the wheel stream was interpolated from its native rate onto the grid, the wheel
    variance is multiplied by ``grid rate / wheel_rate_hz`` so the repeated information is
    not counted several times.

    Parameters
    ----------
    frame : pandas.DataFrame
        ``t_s``, ``vel_l``, ``vel_r`` (m/s), ``wz`` (rad/s). A ``wz`` without a finite
        value leaves ``chi`` at its prior (:func:`estimate_skid_steer` without IMU).
    settings : SkidSteerSettings
        Geometry and tuning.
    wheel_rate_hz : float, optional
        Native wheel rate, Hz, finite and > 0 (default None: the rate is unknown or equal to
        the grid rate, i.e. no inflation).
    gate : Gate, optional
        Per-sensor chi-square gating.

    Returns
    -------
    EKFResult

    Raises
    ------
    DataFormatError
        Missing columns, or a column that is not numeric (booleans, text:
        :class:`~terrain.errors.NonNumericError`, the column named).
    ConfigError
        ``wheel_rate_hz`` not None and not a finite number > 0 (NaN, 0, negative, inf).
    """
    missing = [c for c in (TIME, "vel_l", "vel_r", "wz") if c not in frame.columns]
    if missing:
        raise DataFormatError(f"aligned frame lacks columns {missing}", None, missing[0])
    for c in (TIME, "vel_l", "vel_r", "wz"):
        # (booleans were read as 0 and 1, text as numbers or numpy's bare ValueError)
        if holds_booleans(frame[c]) or not pd.api.types.is_numeric_dtype(frame[c]):
            raise NonNumericError(f"aligned frame column holds {frame[c].dtype} values, not "
                                  "numbers", None, c)
    t = frame[TIME].to_numpy(float)
    rate = float(1.0 / np.median(np.diff(t))) if t.size > 1 else 1.0
    scale = wheel_r_scale(rate, wheel_rate_hz)
    samples = {"wheels": SensorSamples(t, frame[["vel_l", "vel_r"]].to_numpy(float)),
               "gyro": SensorSamples(t, frame[["wz"]].to_numpy(float))}
    settings = _without_gyro(settings, samples["gyro"].values)
    result = run_filter(SkidSteerModel(settings, wheel_r_scale=scale), t, samples, gate=gate)
    result.meta.update(model="skid-steer-4", track_m=settings.track_m, wheel_r_scale=scale)
    return result


def skid_steer_on_windows(windows: np.ndarray, rate_hz: float,
                          settings: SkidSteerSettings = SkidSteerSettings(), *,
                          wheel_rate_hz: float | None = None) -> tuple[np.ndarray, ...]:
    """Run the skid-steer EKF on each of many short, gap-free windows, each from the prior.

    The same filter as :func:`skid_steer_on_frame` (no gate) on a frame holding one window,
    without its scheduling and result assembly: the samples of a window are already on one
    regular clock, so the compiled loop (:func:`terrain.estimation.fast.run_compiled`) runs
    on them directly: 0.15-0.20 ms per 200-sample window against 1.6-1.8 ms for
    :func:`skid_steer_on_frame` on a frame of the same window (best of 7, back to back, on the
    shared 2-core machine), whose scheduling dominates for short frames. Equal to it to
    round-off (tested through :func:`features.ekf_signals.window_ekf_channels`).

    Parameters
    ----------
    windows : ndarray, shape (n_windows, 3, n_samples)
        ``vel_l``, ``vel_r`` (m/s) and ``wz`` (rad/s) of each window, every sample finite.
    rate_hz : float
        Sampling rate of the windows, Hz, finite, in ``[MIN_RATE_HZ, MAX_RATE_HZ]`` of
        :mod:`terrain.estimation.runner`.
    settings : SkidSteerSettings
        Geometry and tuning.
    wheel_rate_hz : float, optional
        Native wheel rate, Hz, finite and > 0: the wheel variance is multiplied by
        ``rate_hz / wheel_rate_hz`` (at least 1), as in :func:`skid_steer_on_frame` (default
        None: rate unknown, no inflation).

    Returns
    -------
    x : ndarray, shape (n_windows, n_samples, 4)
        Posterior states (:data:`STATE_NAMES`, SI units).
    y : ndarray, shape (n_windows, n_samples, 3)
        Innovations (:data:`MEASUREMENT_NAMES`; every row is used, no gate).
    nis : ndarray, shape (n_windows, n_samples)
        Normalised innovation squared of each step.

    Raises
    ------
    ShapeError
        ``windows`` not of shape ``(n, 3, n_samples)`` with ``n_samples >= 2``, or holding
        booleans.
    NonFiniteInputError
        A non-finite sample (cut windows around gaps; :func:`skid_steer_on_frame` skips them).
    ConfigError
        ``rate_hz`` not a finite number in ``[MIN_RATE_HZ, MAX_RATE_HZ]``
        (:func:`~terrain.estimation.runner.check_rate_hz`), or ``wheel_rate_hz`` not None and
        not a finite number > 0.
    """
    if holds_booleans(windows):        # (a mask was read as speeds of 0 and 1 m/s)
        raise ShapeError("windows must hold speeds (m/s) and yaw rates (rad/s), got booleans")
    W = np.asarray(windows, dtype=np.float64)
    if W.ndim != 3 or W.shape[1] != 3 or W.shape[2] < 2:
        raise ShapeError(f"windows must be (n_windows, 3, n_samples >= 2), got {W.shape}")
    if not np.isfinite(W).all():
        bad = int(np.argmax(~np.isfinite(W).all(axis=(1, 2))))
        raise NonFiniteInputError(f"window {bad} holds a non-finite sample")
    rate_hz = check_rate_hz(rate_hz, "rate_hz")
    if rate_hz is None:
        raise ConfigError("rate_hz of the windows is required, got None")
    scale = wheel_r_scale(rate_hz, wheel_rate_hz)
    model = SkidSteerModel(settings, wheel_r_scale=scale)
    n_win, _, n = W.shape
    from terrain.estimation.fast import fast_kernel_of, run_compiled

    kernel = fast_kernel_of(model)
    dts = np.full(n - 1, 1.0 / float(rate_hz))
    row_sensor = sensor_groups(SENSOR_ROWS, len(MEASUREMENT_NAMES))
    x0, P0, R_diag = model.x0, model.P0, model.R_diag
    x = np.empty((n_win, n, len(STATE_NAMES)))
    y = np.empty((n_win, n, len(MEASUREMENT_NAMES)))
    nis = np.empty((n_win, n))
    for i in range(n_win):
        loop = run_compiled(kernel, dts, W[i].T, x0, P0, R_diag, row_sensor, len(SENSOR_ROWS))
        x[i], y[i], nis[i] = loop.x, loop.y, loop.nis
    return x, y, nis


def icr_chi(result: EKFResult) -> np.ndarray:
    """ICR factor ``chi = exp(log_icr_chi)`` over time from a skid-steer result.

    Parameters
    ----------
    result : EKFResult
        Output of :func:`estimate_skid_steer` or :func:`skid_steer_on_frame`.

    Returns
    -------
    ndarray, shape (N,)
        Dimensionless.
    """
    return np.exp(result.state("log_icr_chi"))
