"""Physics-based longitudinal slip from the drive force (no absolute velocity sensor needed).

The chain, every relation called from where it is defined (nothing re-typed):

1. motor current -> wheel torque: the vehicle's motor law
   :meth:`terrain.vehicles.MotorParams.current_from_torque` (``I = I_0 tanh(omega / 0.05 rad/s)
   + T / (G k_t eta)``, Husky A200 constants in :mod:`terrain.vehicles.skid_steer`) is affine in
   the torque, so it is inverted by evaluating it at two torques
   (:func:`wheel_torque_from_current`);
2. wheel torque -> gross traction coefficient: the simulator's torque law
   :func:`terrain.sim.forces.contact_torque_nm` (``T_i = r N_i (mu + h tanh(omega r / v_h))``,
   torque-only rolling loss ``h`` of the terrain), again affine in ``mu``, with the normal loads
   of :func:`terrain.sim.forces.contact_layout` at the pitch measured by the accelerometer
   (grade: ``N = m g cos(pitch) x share``) and the wheel inertia torque removed
   (:func:`traction_from_torque`). Grade and soil resistance act on the body, not on the wheel
   torque: they set how much the body accelerates (``m a_x = N (mu - f_soil) - m g sin(pitch)``,
   seed 003 eq. 10), which the accelerometer's specific force ``a_x + g sin(pitch)`` shows;
3. traction coefficient -> slip on the stable side of the terrain's curve:
   :func:`terrain.terramechanics.inverse.slip_from_traction`.

Terrain from a classifier: the slip is computed under every terrain with a non-negligible
probability and the results are **probability-weighted** (Bayesian model averaging over the
terrain class), with the spread between terrains added to the variance (law of total
variance). Why not the most-likely curve: when the classifier hesitates between grounds with
different curves (SNOW vs SANDY_LOAM), the most-likely curve gives a confident but possibly
wrong slip; the weighted mean minimises the expected squared error under the classifier's
posterior, and its interval widens honestly. With a confident classifier both coincide.

Uncertainty (first order, at ``coverage_sigma`` standard deviations): current noise, relative
uncertainty of the gearbox efficiency (ASSUMED in the Husky motor parameters) and of the
calibrated rolling loss; the interval on ``mu`` is mapped through the monotone inverse curve,
so the slip interval is exact for that ``mu`` interval (asymmetric near the peak). An end
of the ``mu`` interval at or past the curve's maximum traction maps to full slip (+-1): every
slip past the peak delivers that traction, so a spinning wheel (e.g. a start on ice) gets a
wide interval instead of the peak slip with a small std. A curve that rises up to full slip
(Janosi: SNOW, SANDY_LOAM, GRASS, GRAVEL; Brixius) has no slip past its peak, so a ``mu``
interval lying wholly at or above its maximum would map to the single point +-1 (std 0); its
other end is then the slip at the maximum less the interval's width (the traction both the
current and the curve allow is the top of the curve), so that interval is wide too
(:func:`_slip_interval`). The slip estimate itself is then the stable side's end, the peak
slip (+-1 only on a curve rising to full slip; :func:`slip_from_traction` saturates there):
the current asks for at least the most the curve gives, so the slip is not measured, only
bounded (the batch estimate uses the interval's centre with the physics std instead, or
skips the window-side when the interval is not given, and counts them:
:func:`terrain.slip.estimate.estimate_skid_steer_slip_run`).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Mapping, NamedTuple

import numpy as np

from terrain.errors import ConfigError, ShapeError, config_numbers, config_positive
from terrain.estimation.consistency import integrated_autocorrelation_time
from terrain.sim.forces import contact_layout, contact_torque_nm
from terrain.sim.sensors import SensorSettings
from terrain.terramechanics.catalogue import TerrainParams, get_terrain
from terrain.terramechanics.inverse import slip_from_traction, stable_side
from terrain.terramechanics.resistance import G_M_S2
from terrain.vehicles.common import drive_inertia_kg_m2


@dataclass(frozen=True)
class PhysicsSlipSettings:
    """Uncertainties of the physics slip.

    Parameters
    ----------
    current_std_a : float
        Std of one current sample, A (default: the simulated sensor's
        :attr:`terrain.sim.sensors.SensorSettings.current_noise_a`).
    efficiency_rel_std : float
        Relative std of the gearbox efficiency (ASSUMED 0.1: the Husky value 0.8 is itself
        assumed, :mod:`terrain.vehicles.skid_steer`).
    hysteresis_rel_std : float
        Relative std of the terrain's calibrated rolling loss ``h`` (ASSUMED 0.15: the
        calibration matches one mean current per terrain,
        :mod:`terrain.terramechanics.calibration`).
    coverage_sigma : float
        Half-width of the reported interval in standard deviations (2 ~ 95 %).
    min_probability : float
        Terrains below this classifier probability are ignored (weights renormalised), in
        [0, 1).

    Raises
    ------
    ConfigError
        A value that is not a real number (:func:`terrain.errors.config_numbers`), an
        uncertainty that is not finite and >= 0, a ``coverage_sigma`` not finite and > 0, or
        a ``min_probability`` outside [0, 1).
    """

    current_std_a: float = SensorSettings.current_noise_a
    efficiency_rel_std: float = 0.1
    hysteresis_rel_std: float = 0.15
    coverage_sigma: float = 2.0
    min_probability: float = 1e-3

    def __post_init__(self) -> None:
        # (NaN passed a '< 0' check and made every std NaN)
        config_positive("PhysicsSlipSettings", allow_zero=True, current_std_a=self.current_std_a,
                        efficiency_rel_std=self.efficiency_rel_std,
                        hysteresis_rel_std=self.hysteresis_rel_std)
        config_positive("PhysicsSlipSettings", coverage_sigma=self.coverage_sigma)
        config_numbers("PhysicsSlipSettings", min_probability=self.min_probability)
        if not 0.0 <= self.min_probability < 1.0:
            raise ConfigError(f"PhysicsSlipSettings.min_probability must be in [0, 1), got "
                              f"{self.min_probability}")


class PhysicsSlip(NamedTuple):
    """Physics slip of each drive side (n samples or windows, m motors).

    Attributes
    ----------
    slip : ndarray, shape (n, m)
        Longitudinal SAE slip estimate (dimensionless).
    std : ndarray, shape (n, m)
        Standard deviation (interval half-width over ``coverage_sigma``).
    lower, upper : ndarray, shape (n, m)
        Interval at ``coverage_sigma``.
    mu : ndarray, shape (n, m)
        Probability-weighted gross traction coefficient.
    saturated : ndarray of bool, shape (n, m)
        The curve of each row's most probable terrain was asked for its maximum traction or
        more (with several equally probable terrains, the curve of any of them).
    """

    slip: np.ndarray
    std: np.ndarray
    lower: np.ndarray
    upper: np.ndarray
    mu: np.ndarray
    saturated: np.ndarray


def _affine(fn, x_at_0, x_at_1):
    a = fn(x_at_0)
    return a, fn(x_at_1) - a


def wheel_torque_from_current(motor, current_a: np.ndarray, omega_rad_s: np.ndarray
                              ) -> np.ndarray:
    """Wheel torque that draws a signed motor current (inverse of the motor law).

    Inverts :meth:`terrain.vehicles.MotorParams.current_from_torque` (affine in the
    torque) by evaluating it at 0 and 1 N m.

    Parameters
    ----------
    motor : MotorParams
        Motor of the vehicle (``vehicle.motor``).
    current_a : ndarray, shape (...)
        Signed motor current, A (positive drives forward).
    omega_rad_s : ndarray, shape (...)
        Wheel speed, rad/s.

    Returns
    -------
    ndarray, shape (...)
        Wheel torque, N m.
    """
    w = np.asarray(omega_rad_s, dtype=float)
    a, b = _affine(lambda t: motor.current_from_torque(np.full_like(w, t), w), 0.0, 1.0)
    return (np.asarray(current_a, dtype=float) - a) / b


def pitch_from_accelerometer(ax_m_s2: np.ndarray, ay_m_s2: np.ndarray, az_m_s2: np.ndarray,
                             accel_long_m_s2: np.ndarray | float = 0.0) -> np.ndarray:
    """Nose-up pitch from the specific force ``(a_x - dv/dt, a_y, a_z) = g (sin p, ., cos p)``.

    Parameters
    ----------
    ax_m_s2, ay_m_s2, az_m_s2 : ndarray, shape (...)
        Accelerometer (window means to average out vibration), m/s^2, body axes x forward,
        z up.
    accel_long_m_s2 : float or ndarray, shape (...)
        Longitudinal body acceleration to remove (e.g. the slope of the wheel speed), m/s^2.

    Returns
    -------
    ndarray, shape (...)
        Pitch, rad (positive nose-up, climbing).
    """
    ax = np.asarray(ax_m_s2, dtype=float) - np.asarray(accel_long_m_s2, dtype=float)
    return np.arctan2(ax, np.hypot(np.asarray(ay_m_s2, dtype=float),
                                   np.asarray(az_m_s2, dtype=float)))


def pitch_std_from_accelerometer(ax_samples_m_s2: np.ndarray) -> np.ndarray:
    """Standard deviation of the window-mean pitch of :func:`pitch_from_accelerometer` that
    the accelerometer's vibration leaves, rad.

    ``sqrt(tau var(a_x) / N) / g``: the noise of the window mean of ``a_x`` (``N`` samples,
    vibration correlated over ``tau`` samples, the integrated autocorrelation time of
    :func:`terrain.estimation.consistency.integrated_autocorrelation_time`) over gravity,
    the slope of ``arcsin(a_x / g)`` near level. On simulated level runs it matches the
    spread of the window pitch within 4 % (SNOW 0.057 against 0.058 rad, SANDY_LOAM 0.026
    against 0.027, GRASS 0.0076 against 0.0079; ``docs/slip_learning.md``).

    Parameters
    ----------
    ax_samples_m_s2 : ndarray, shape (..., N)
        Longitudinal accelerometer samples of each window, m/s^2.

    Returns
    -------
    ndarray, shape (...)
        Pitch std, rad (0 for a constant window).
    """
    x = np.asarray(ax_samples_m_s2, dtype=float)
    n = x.shape[-1]
    if n < 2:
        return np.zeros(x.shape[:-1])
    tau = integrated_autocorrelation_time(x, max_lag=max(n // 4, 2))
    return np.sqrt(np.var(x, axis=-1) * tau / n) / G_M_S2


def normal_load_factor(pitch_rad: np.ndarray, pitch_std_rad: np.ndarray | None,
                       pitch_prior: tuple[float, float] | None = None
                       ) -> tuple[np.ndarray, np.ndarray]:
    """Correction of the ``cos(pitch)`` normal load for a noisy pitch, and its relative std.

    For a pitch estimate ``p + e`` with Gaussian ``e`` of std ``sigma``,
    ``E[cos(p + e)] = cos(p) exp(-sigma^2 / 2)``: the load computed at the estimate is low
    by that factor on average, so it is multiplied by ``exp(sigma^2 / 2)``, which makes it
    unbiased; what is left is a relative error of std
    ``sqrt(tan(p)^2 sigma^2 + sigma^4 / 2)`` (first order in ``e`` on a slope, second order
    on level ground), with ``tan(p)^2`` estimated by ``max(tan(p + e)^2 - sigma^2, 0)``.
    Without it the slip from a vibrating accelerometer is biased high: +0.001 on simulated
    SNOW, where the window pitch has a std of 0.058 rad (``docs/slip_learning.md``).

    That positive part is itself high on level ground (it averages ``0.48 sigma^2`` where
    ``p = 0``: the SNOW slip std about 10 % too wide). With ``pitch_prior`` (the true pitch's
    mean and variance over the run, :func:`run_pitch_prior`) ``p^2`` is instead its
    posterior mean under that Gaussian prior (small angles, empirical Bayes):
    ``(m + k (p_hat - m))^2 + k sigma^2`` with ``k = tau^2 / (tau^2 + sigma^2)``; on level
    ground ``tau^2 ~ 0`` and the estimate is ``m^2 ~ 0``, on a slope it follows ``p_hat``.

    Parameters
    ----------
    pitch_rad : ndarray, shape (n,)
        Pitch estimate, rad.
    pitch_std_rad : ndarray, shape (n,), or None
        Its std (:func:`pitch_std_from_accelerometer`), rad; None: exact pitch.
    pitch_prior : (float, float) or None
        Mean (rad) and variance (rad^2) of the true pitch over the run; None: the positive
        part above.

    Returns
    -------
    factor : ndarray, shape (n,)
        Multiplier of the normal loads at ``pitch_rad``.
    rel_std : ndarray, shape (n,)
        Relative std of the corrected normal load.
    """
    p = np.asarray(pitch_rad, dtype=float)
    if pitch_std_rad is None:
        return np.ones_like(p), np.zeros_like(p)
    s2 = np.broadcast_to(np.nan_to_num(np.asarray(pitch_std_rad, dtype=float)) ** 2, p.shape)
    if pitch_prior is None:
        # tan(p)^2 from the estimate is itself high by sigma^2 on average: remove it
        tan2 = np.maximum(np.tan(p) ** 2 - s2, 0.0)
    else:
        m, tau2 = float(pitch_prior[0]), max(float(pitch_prior[1]), 0.0)
        k = np.divide(tau2, tau2 + s2, out=np.ones_like(s2), where=(tau2 + s2) > 0)
        tan2 = np.tan(m + k * (p - m)) ** 2 + k * s2
    return np.exp(0.5 * s2), np.sqrt(tan2 * s2 + 0.5 * s2 ** 2)


def run_pitch_prior(pitch_rad: np.ndarray, pitch_std_rad: np.ndarray) -> tuple[float, float]:
    """Mean and variance of the true pitch over a run's windows (method of moments).

    ``mean(p_hat)`` and ``max(var(p_hat) - mean(sigma^2), 0)``: the spread of the window
    pitch estimates beyond their own noise (:func:`normal_load_factor`'s ``pitch_prior``).

    Parameters
    ----------
    pitch_rad : ndarray, shape (n,)
        Window pitch estimates of one run, rad.
    pitch_std_rad : ndarray, shape (n,)
        Their stds (:func:`pitch_std_from_accelerometer`), rad.

    Returns
    -------
    tuple of float
        Mean, rad, and variance, rad^2 (>= 0).

    Raises
    ------
    ShapeError
        The arrays differ in shape or hold no finite pair.
    """
    p = np.asarray(pitch_rad, dtype=float)
    sd = np.asarray(pitch_std_rad, dtype=float)
    if p.shape != sd.shape:
        raise ShapeError(f"pitch {p.shape} and its std {sd.shape} differ in shape")
    ok = np.isfinite(p) & np.isfinite(sd)
    if not ok.any():
        raise ShapeError("no finite window pitch to estimate the run's pitch from")
    p, sd = p[ok], sd[ok]
    return float(p.mean()), float(max(p.var() - np.mean(sd ** 2), 0.0))


def traction_from_torque(vehicle, terrain: TerrainParams, torque_nm: np.ndarray,
                         rim_speed_m_s: np.ndarray, pitch_rad: np.ndarray,
                         wheel_accel_rad_s2: np.ndarray | None = None,
                         pitch_std_rad: np.ndarray | None = None
                         ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Gross traction coefficient of each drive side from its wheel torque.

    Inverts :func:`terrain.sim.forces.contact_torque_nm` (affine in ``mu``), all contacts
    of a side sharing one ``mu``; the wheel inertia torque
    ``J d omega / dt`` (:func:`terrain.vehicles.common.drive_inertia_kg_m2`) is removed
    first.

    Parameters
    ----------
    vehicle : HuskyParams or TrackedParams
        Skid-steer vehicle (mass, contact geometry, motor).
    terrain : TerrainParams
        Terrain (rolling loss ``hysteresis``).
    torque_nm : ndarray, shape (n, m)
        Wheel torque of each motor, N m.
    rim_speed_m_s : ndarray, shape (n, m)
        Rim speed ``omega r`` of each motor, m/s.
    pitch_rad : ndarray, shape (n,)
        Nose-up pitch, rad (normal loads scale with its cosine); NaN: no normal load, the
        row's outputs are NaN.
    wheel_accel_rad_s2 : ndarray, shape (n, m), optional
        Wheel angular acceleration, rad/s^2 (None = 0, steady driving).
    pitch_std_rad : ndarray, shape (n,), optional
        Std of the pitch estimate, rad: the normal loads are corrected by
        :func:`normal_load_factor` (None: exact pitch).

    Returns
    -------
    mu : ndarray, shape (n, m)
        Gross traction coefficient (dimensionless; NaN on the rows without a pitch).
    dmu_dtorque : ndarray, shape (n, m)
        ``d mu / d T``, 1/(N m).
    rolling_mu : ndarray, shape (n, m)
        Rolling-loss part subtracted (``torque at mu = 0`` over ``d T / d mu``).

    Raises
    ------
    ShapeError
        Shapes do not match ``(n, n_motors)`` and ``(n,)``.
    """
    geometry = vehicle.contact_geometry()
    torque = np.asarray(torque_nm, dtype=float)
    rim = np.asarray(rim_speed_m_s, dtype=float)
    pitch = np.asarray(pitch_rad, dtype=float)
    nm = geometry.n_motors
    if torque.ndim != 2 or torque.shape[1] != nm or rim.shape != torque.shape \
            or pitch.shape != torque.shape[:1]:
        raise ShapeError(f"torque and rim speed must be (n, {nm}) and pitch (n,), got "
                         f"{torque.shape}, {rim.shape}, {pitch.shape}")
    motor_of = geometry.motor_of_contact
    # a row without a pitch (NaN: no accelerometer mean) has no normal load: NaN, not filled
    a = np.full_like(torque, np.nan)
    b = np.full_like(torque, np.nan)
    # normal loads scale with cos(pitch): one layout per distinct pitch value
    for p in np.unique(np.round(pitch, 4)):
        rows = np.round(pitch, 4) == p
        layout = contact_layout(geometry, vehicle.mass_kg, float(p), 1.0)
        rim_c = rim[rows][:, motor_of]
        t0 = contact_torque_nm(layout, terrain, np.zeros_like(rim_c), rim_c)
        t1 = contact_torque_nm(layout, terrain, np.ones_like(rim_c), rim_c)
        a[rows] = np.stack([t0[:, motor_of == j].sum(axis=1) for j in range(nm)], axis=1)
        b[rows] = np.stack([(t1 - t0)[:, motor_of == j].sum(axis=1) for j in range(nm)],
                           axis=1)
    # torques are linear in the normal loads: scale both parts by the load correction
    factor, _ = normal_load_factor(pitch, pitch_std_rad)
    a *= factor[:, None]
    b *= factor[:, None]
    inertia = 0.0 if wheel_accel_rad_s2 is None else (
        drive_inertia_kg_m2(vehicle) * np.asarray(wheel_accel_rad_s2, float))
    return (torque - inertia - a) / b, 1.0 / b, a / b


def within_window_current_std(current_within_std_a: np.ndarray | None, noise_std_a: float,
                              shape: tuple[int, ...]) -> np.ndarray:
    """Spread of the current inside a window beyond the sensor noise, A.

    ``sqrt(max(s^2 - sigma_n^2, 0))`` with ``s`` the std of the window's current samples and
    ``sigma_n`` the std of one sample's noise: 0 for a steady window (the noise of the mean
    is counted separately), about ``s`` in a transient. The traction-slip curve is
    nonlinear (flat past the knee on ice, seed 001 ch. 8.2), so the slip at the window's
    mean traction can be far from the window's mean slip when the traction varies inside
    the window; this spread, mapped through the current-to-traction gain, bounds that error
    to first order.

    Parameters
    ----------
    current_within_std_a : ndarray, shape (n, m), or None
        Std of the current samples inside each window, A; None: zeros. NaN where it is
        not known (a window holding a non-finite current sample).
    noise_std_a : float
        Std of one current sample's noise, A (:attr:`PhysicsSlipSettings.current_std_a`).
    shape : tuple of int
        ``(n, m)`` of the physics slip.

    Returns
    -------
    ndarray, shape (n, m)
        Excess spread, A (>= 0); NaN where the spread is NaN: a window whose steadiness is
        unknown is not taken as steady (its physics slip std and interval are then NaN,
        which the slip pseudo-measurement skips and counts, see
        :func:`terrain.estimation.skid_steer_slip.run_with_pseudo_slip`).

    Raises
    ------
    ShapeError
        ``current_within_std_a`` does not have ``shape``.
    """
    if current_within_std_a is None:
        return np.zeros(shape)
    s = np.asarray(current_within_std_a, dtype=float)
    if s.shape != tuple(shape):
        raise ShapeError(f"current_within_std_a must be {tuple(shape)}, got {s.shape}")
    # NaN stays NaN (np.maximum propagates it): unknown, not steady
    return np.sqrt(np.maximum(s ** 2 - noise_std_a ** 2, 0.0))


def _slip_interval(curve, mu_low: np.ndarray, mu_high: np.ndarray
                   ) -> tuple[np.ndarray, np.ndarray]:
    """Slip interval of a traction interval on the stable side, open past the peak.

    Below the curve's maximum traction the stable-side inverse is exact. A traction at or
    beyond the maximum is delivered by every slip past the peak (the wheel spins: the
    traction-slip curve is flat or falling there, seed 001 ch. 8.2), so that end of the
    interval is the full slip, +1 (or -1 when braking), not the peak slip.

    When both ends are at or beyond the maximum on the same side and the stable side of the
    curve ends at full slip (a curve rising up to ``|s| = 1``: Janosi, Brixius), there is no
    slip past the peak and the interval would collapse to +-1 with width 0. The traction
    that both the current and the curve allow is then the top of the curve, an interval of
    the same width ending at the maximum: the other end is the slip at
    ``mu_max - (mu_high - mu_low)`` (mirrored when braking). A curve with slip past its
    table's end (ICE's flat top, Burckhardt with a falling side) keeps the end of its
    stable side there.

    An infinite end is beyond the maximum like any other: ``+inf`` as the upper end gives
    +1, ``-inf`` as the lower end -1 (the limit of ever larger finite ends). On a curve
    rising to full slip, an interval with one infinite end is infinitely wide, so its
    other end is the opposite full slip; two ends at the same infinity have width 0, as
    any two equal ends (``inf - inf`` would be NaN). A NaN end stays NaN.

    Parameters
    ----------
    curve : TractionCurve
        Terrain's traction-slip curve.
    mu_low, mu_high : ndarray, shape (n, m)
        Ends of the gross traction coefficient interval (dimensionless; +-inf allowed).

    Returns
    -------
    lower, upper : ndarray, shape (n, m)
        Slip interval (dimensionless).
    """
    lo = slip_from_traction(curve, mu_low)
    hi = slip_from_traction(curve, mu_high)
    lower = np.where(lo.saturated & (mu_low < 0), -1.0, lo.slip)
    upper = np.where(hi.saturated & (mu_high > 0), 1.0, hi.slip)
    s_grid, mu_grid = stable_side(curve)
    if s_grid[-1] >= 1.0:
        # no slip past the peak: the top of the curve, of the interval's width
        high, low = np.asarray(mu_high, float), np.asarray(mu_low, float)
        # equal ends have width 0, the same infinity included (inf - inf is NaN)
        with np.errstate(invalid="ignore"):
            width = high - low
        top = mu_grid[-1] - np.where(high == low, 0.0, width)
        at_top = slip_from_traction(curve, top).slip
        lower = np.where(lo.saturated & (mu_low > 0), np.minimum(at_top, lower), lower)
        upper = np.where(hi.saturated & (mu_high < 0), np.maximum(-at_top, upper), upper)
    return lower, upper


def _normalise(probabilities: Mapping[str, np.ndarray | float], n: int,
               min_p: float) -> dict[str, np.ndarray]:
    if not probabilities:
        raise ConfigError("terrain probabilities are empty")
    names = list(probabilities)
    for k in names:
        if np.shape(probabilities[k]) not in ((), (n,)):
            raise ShapeError(f"terrain probability of {k} must be one number or have shape "
                             f"({n},), got {np.shape(probabilities[k])}")
    p = np.column_stack([np.broadcast_to(np.asarray(probabilities[k], float), (n,))
                         for k in names])
    if np.any(p < 0) or not np.all(np.isfinite(p)):
        raise ConfigError("terrain probabilities must be finite and >= 0")
    p = np.where(p >= min_p, p, 0.0)
    total = p.sum(axis=1, keepdims=True)
    if np.any(total <= 0):      # (it said "sum to 0" of rows summing to 0.0006)
        rows = np.flatnonzero(total[:, 0] <= 0)
        raise ConfigError(f"terrain probabilities: {rows.size} row(s) (first {rows[0]}) hold "
                          f"no terrain probability >= min_probability {min_p:g} (the "
                          "probabilities below it are dropped as noise): give each row the "
                          "classifier's probabilities, which sum to 1")
    p = p / total
    return {k: p[:, i] for i, k in enumerate(names) if np.any(p[:, i] > 0)}


def physics_slip(vehicle, terrain_probabilities: Mapping[str, np.ndarray | float],
                 current_a: np.ndarray, rim_speed_m_s: np.ndarray, pitch_rad: np.ndarray,
                 wheel_accel_rad_s2: np.ndarray | None = None, n_averaged: np.ndarray | float = 1.0,
                 settings: PhysicsSlipSettings = PhysicsSlipSettings(),
                 current_within_std_a: np.ndarray | None = None,
                 pitch_std_rad: np.ndarray | None = None,
                 pitch_prior: tuple[float, float] | None = None) -> PhysicsSlip:
    """Longitudinal slip of each drive side from motor currents (module docstring).

    Parameters
    ----------
    vehicle : HuskyParams or TrackedParams
        Skid-steer vehicle.
    terrain_probabilities : mapping str -> float or ndarray, shape (n,)
        Classifier probability of each catalogue terrain (per row or constant); a single
        ``{"SNOW": 1.0}`` for a known ground.
    current_a : ndarray, shape (n, m)
        Motor current magnitudes as logged (``cur_l, cur_r``), A; the sign is taken from the
        wheel speed (driving assumption: a braking side reads as driving); a side at rest
        (rim speed exactly 0) holds against either direction, so there both signs weigh half
        (a mixture, like the terrains': its spread is in the std and the interval).
    rim_speed_m_s : ndarray, shape (n, m)
        Wheel rim speeds (``vel_l, vel_r``), m/s.
    pitch_rad : ndarray, shape (n,)
        Nose-up pitch (:func:`pitch_from_accelerometer`), rad.
    wheel_accel_rad_s2 : ndarray, shape (n, m), optional
        Wheel angular acceleration, rad/s^2 (None = steady).
    n_averaged : float or ndarray, shape (n,)
        Number of current samples averaged into each row (the current noise shrinks with
        its square root).
    settings : PhysicsSlipSettings
        Uncertainties and coverage.
    current_within_std_a : ndarray, shape (n, m), optional
        Standard deviation of the current samples inside each row's window, A (None: rows
        are single samples or steady windows). Its part above the sensor noise is traction
        that changed inside the window (a start, a spin, a step): the slip of the mean
        traction is then not the mean slip, so that spread is added to the traction
        interval (:func:`within_window_current_std`).
    pitch_std_rad : ndarray, shape (n,), optional
        Std of ``pitch_rad`` (:func:`pitch_std_from_accelerometer`), rad: the normal loads
        are made unbiased and their remaining error is added to the traction uncertainty
        (:func:`normal_load_factor`); None: exact pitch.
    pitch_prior : (float, float), optional
        Mean (rad) and variance (rad^2) of the true pitch over the run
        (:func:`run_pitch_prior`), for that remaining error; None: per window only.

    Returns
    -------
    PhysicsSlip

    Raises
    ------
    ConfigError
        Unknown terrain name or invalid probabilities (negative, not finite, or a row
        without any at or above ``settings.min_probability``, naming the first such row);
        ``n_averaged`` not > 0 (0, negative or NaN: the current noise would be NaN).
    ShapeError
        Inconsistent shapes: ``current_a`` and ``rim_speed_m_s`` not one ``(n, m)`` shape,
        ``pitch_rad`` not ``(n,)``, or ``pitch_std_rad``, ``n_averaged``, a terrain
        probability (``(n,)``) or ``wheel_accel_rad_s2`` (``(n, m)``) neither that nor one
        number; the message names the argument.
    """
    cur = np.abs(np.asarray(current_a, dtype=float))
    rim = np.asarray(rim_speed_m_s, dtype=float)
    if cur.shape != rim.shape or cur.ndim != 2:
        raise ShapeError(f"current and rim speed must share a shape (n, m), got {cur.shape}, "
                         f"{rim.shape}")
    n, m = cur.shape
    for name, value, allowed in (("pitch_rad", pitch_rad, ((n,),)),
                                 ("pitch_std_rad", pitch_std_rad, ((), (n,))),
                                 ("wheel_accel_rad_s2", wheel_accel_rad_s2, ((), (n, m))),
                                 ("n_averaged", n_averaged, ((), (n,)))):
        if value is not None and np.shape(value) not in allowed:
            raise ShapeError(f"{name} must have shape {' or '.join(map(str, allowed))} for "
                             f"{n} rows of {m} motors, got {np.shape(value)}")
    n_avg = np.asarray(n_averaged, dtype=float)
    if not np.all(n_avg > 0):           # one comparison: 0, < 0 and NaN all fail it
        raise ConfigError(f"n_averaged must be > 0 (a count of current samples), got "
                          f"{n_avg[~(n_avg > 0)][:5] if n_avg.ndim else n_avg}")
    probs = _normalise(terrain_probabilities, n, settings.min_probability)
    radius = vehicle.contact_geometry().wheel_radius_m
    omega = rim / radius
    # a side at rest (rim speed 0) holds against either direction: its reported current
    # magnitude has no sign, so both signs weigh half there (a forward one alone made a
    # reversing start the mirror of no forward one)
    at_rest = rim == 0.0
    signs = [(np.where(rim < 0, -cur, cur), np.where(at_rest, 0.5, 1.0))]
    if at_rest.any():
        signs.append((np.where(at_rest, -cur, cur), np.where(at_rest, 0.5, 0.0)))
    k = settings.coverage_sigma
    sd_i = settings.current_std_a / np.sqrt(np.broadcast_to(n_avg, (n,)))[:, None]
    sd_within = within_window_current_std(current_within_std_a, settings.current_std_a,
                                          cur.shape)
    mean = np.zeros_like(cur)
    terms = []                          # (weight, slip) of each terrain and sign
    within = np.zeros_like(cur)
    lower = np.zeros_like(cur)
    upper = np.zeros_like(cur)
    mu_w = np.zeros_like(cur)
    saturated = np.zeros(cur.shape, dtype=bool)
    best_p = np.full(cur.shape[0], -np.inf)   # each row's most probable terrain so far
    # the traction is torque over normal load: a relative load error is a relative error of
    # mu + rolling (= torque / d torque / d mu)
    load_rel_std = normal_load_factor(np.asarray(pitch_rad, dtype=float),
                                      pitch_std_rad, pitch_prior)[1][:, None]
    for flipped, (signed, share) in enumerate(signs):
        torque = wheel_torque_from_current(vehicle.motor, signed, omega)
        dtorque_di = wheel_torque_from_current(vehicle.motor, signed + 1.0, omega) - torque
        for name, p in probs.items():
            terrain = get_terrain(name)
            mu, dmu_dt, rolling = traction_from_torque(vehicle, terrain, torque, rim,
                                                       pitch_rad, wheel_accel_rad_s2,
                                                       pitch_std_rad)
            sd_mu = np.sqrt((dmu_dt * dtorque_di * sd_i) ** 2
                            + (dmu_dt * torque * settings.efficiency_rel_std) ** 2
                            + (rolling * settings.hysteresis_rel_std) ** 2
                            + (dmu_dt * dtorque_di * sd_within) ** 2
                            + ((mu + rolling) * load_rel_std) ** 2)
            est = slip_from_traction(terrain.curve, mu)
            lo, hi = _slip_interval(terrain.curve, mu - k * sd_mu, mu + k * sd_mu)
            sd = (hi - lo) / (2.0 * k)
            w = p[:, None] * share
            mean += w * est.slip
            terms.append((w, est.slip))
            within += w * sd ** 2
            lower += w * lo
            upper += w * hi
            mu_w += w * mu
            p_row = np.asarray(p, dtype=float)
            if flipped:     # the other sign of a side at rest: the same terrain's flag too
                saturated |= est.saturated & at_rest & (p_row == best_p)[:, None]
                continue
            # a tie flags where any of the tied curves saturates (the first listed won
            # before: the flag followed the order of the classes)
            tied = p_row == best_p
            saturated[tied] |= est.saturated[tied]
            better = p_row > best_p
            saturated[better] = est.saturated[better]
            best_p[better] = p_row[better]
    # law of total variance: within-terrain variance + spread of the terrain-wise slips,
    # the spread summed about the mean (E[s^2] - E[s]^2 cancelled: terrains of one slip
    # left a rounding of 1e-16, whose root, 1e-8, moved the interval with the order of the
    # classes)
    between = np.sqrt(sum(w * (slip - mean) ** 2 for w, slip in terms))
    std = np.sqrt(within + between ** 2)
    return PhysicsSlip(mean, std, np.clip(lower - k * between, -1, 1),
                       np.clip(upper + k * between, -1, 1), mu_w, saturated)
