"""Wheel-only features that carry the drive physics of a skid-steer robot.

For robots that log no IMU, the terrain shows in how much motor current the drive needs for
the motion it makes. A DC drive's current magnitude grows with the wheel torque (the
BorealTC / Husky currents are magnitudes, >= 0), and on level ground the torque balances
rolling/soil resistance, inertia and, for a skid-steer, the turning-resistance moment of
Coulomb-like lateral friction (Wong, *Theory of Ground Vehicles*, 4th ed., ch. 7.2,
eq. 7.40: ``M_r = mu_lat W L / 4``, independent of the yaw rate once the wheels skid; see
:func:`terrain.terramechanics.turning_resistance_moment_nm`). With ``v = (v_L + v_R)/2``
(m/s), ``a = dv/dt`` (m/s^2), the commanded yaw rate ``omega = (v_R - v_L)/B`` (rad/s) and
the saturating motion indicators ``m_v = tanh(|v| / v0)``, ``m_w = tanh(|omega| / w0)``,
each window is fitted by ridge least squares (the no-load term ``c0`` unpenalised, as
scikit-learn's ``Ridge`` leaves its intercept, so a current-sensor offset moves ``c0`` alone)
to two current balances::

    I_L + I_R = c0 + c1 m_v + c2 |a| + c3 m_w + e_sum              (magnitudes)
    I_R - I_L = d0 sgn(omega) m_v + d1 omega + e_diff              (arcs)

``c0`` is the no-load current (A), ``c1`` the current the terrain's motion resistance costs
when driving (A), ``c2`` the current per unit acceleration (inertia plus slip, A s^2/m),
``c3`` the current of skidding round (turning resistance, A: in-place turns load both
sides), ``d0`` the side-to-side current of turning on an arc (A, it scales with
``mu_lat``), ``d1`` a viscous term (A s/rad). Beside the coefficients come the residual
spreads (unexplained current, rough ground), the mean current while turning and while
driving straight, current per unit speed and per unit yaw-rate command, quantiles and the
operating point (speed, yaw-rate, acceleration levels) the classifier needs to read the
currents in context. Every feature is computed over the whole window and over its last
``short_s`` seconds (two time scales). Names follow ``<signal>__<feature>[__<param>]``.
"""

from __future__ import annotations

import numba
import numpy as np
from sklearn.base import BaseEstimator, TransformerMixin
from sklearn.utils.validation import check_is_fitted

from features.calculators import quantile_sorted
from features.windows import (HUSKY_TRACK_M, as_windows, refuse_changed_layout,
                              refuse_non_finite)
from terrain.errors import (ConfigError, NonFiniteInputError, ShapeError, config_numbers,
                            config_positive, duplicated, first_items, real_arrays)
from terrain.io.align import DEFAULT_RATE_HZ
from terrain.run import WHEEL_CHANNELS
from terrain.vehicles.skid_steer import body_rates

#: Feature names of one time scale, in output order.
PHYSICS_FEATURES = (
    "cur_sum__noload_a", "cur_sum__drive_a", "cur_sum__inertia_a_s2_per_m",
    "cur_sum__turn_a", "cur_sum__resid_std_a", "cur_diff__arc_turn_a",
    "cur_diff__viscous_a_s_per_rad", "cur_diff__resid_std_a", "cur_sum__turning_mean_a",
    "cur_sum__straight_mean_a", "cur_sum__per_speed", "cur_sum__per_yaw_rate",
    "cur_sum__q10", "cur_sum__q50", "cur_sum__q90", "cur_diff_abs__q50", "cur_diff_abs__q90",
    "cur_sum__ripple_a", "vel_mean__abs_mean", "vel_mean__std", "yaw_rate_cmd__abs_mean",
    "yaw_rate_cmd__std", "accel__abs_mean", "moving__fraction", "turning__fraction",
)


@numba.njit(cache=True, nogil=True)
def _ridge_fit(y, A, ridge, intercept, coef):   # pragma: no cover - compiled
    """Ridge least squares ``y ~ A coef`` of one window (``A`` n x k); fills ``coef`` and
    returns the residual's standard deviation. With ``intercept`` column 0 of ``A`` is the
    constant 1 and its coefficient is left unpenalised, as scikit-learn's ``Ridge`` with
    ``fit_intercept`` does: the other columns and ``y`` are centred on their window means,
    ``(Ac^T Ac + ridge n I) b = Ac^T yc`` is solved for them and the intercept recovered as
    ``mean(y) - mean(A) b`` (an offset of ``y`` moves the intercept alone). Without it the
    normal equations ``(A^T A + ridge n I) coef = A^T y`` of all columns are solved. LAPACK
    solves them as :func:`numpy.linalg.solve` does (``ridge > 0`` keeps them regular)."""
    n, k = A.shape
    j0 = 1 if intercept else 0
    m = k - j0
    mean_a = np.zeros(k)
    mean_y = 0.0
    if intercept:
        for s in range(n):
            mean_y += y[s]
            for i in range(j0, k):
                mean_a[i] += A[s, i]
        mean_y /= n
        for i in range(j0, k):
            mean_a[i] /= n
    G = np.empty((m, m))
    rhs = np.empty(m)
    for i in range(m):
        for j in range(m):
            g = 0.0
            for s in range(n):
                g += (A[s, j0 + i] - mean_a[j0 + i]) * (A[s, j0 + j] - mean_a[j0 + j])
            G[i, j] = g
        G[i, i] += ridge * n
        r = 0.0
        for s in range(n):
            r += (A[s, j0 + i] - mean_a[j0 + i]) * (y[s] - mean_y)
        rhs[i] = r
    b = np.linalg.solve(G, rhs)
    if intercept:
        c0 = mean_y
        for i in range(m):
            c0 -= mean_a[j0 + i] * b[i]
        coef[0] = c0
    for i in range(m):
        coef[j0 + i] = b[i]
    mean = 0.0
    resid = np.empty(n)
    for s in range(n):
        r = y[s]
        for i in range(k):
            r -= A[s, i] * coef[i]
        resid[s] = r
        mean += r
    return _std(resid, mean / n)


@numba.njit(cache=True, nogil=True)
def _std(x, mean):   # pragma: no cover - compiled
    """Population standard deviation (``ddof=0``) of ``x`` about its ``mean``."""
    ss = 0.0
    for s in range(x.shape[0]):
        ss += (x[s] - mean) ** 2
    return np.sqrt(ss / x.shape[0])


@numba.njit(cache=True, nogil=True)
def _physics_kernel(vel_l, vel_r, cur_l, cur_r, dt, track_m, v0, w0, ridge,
                    out):   # pragma: no cover - compiled
    n_windows, n = vel_l.shape
    v, om, i_sum, i_diff = np.empty(n), np.empty(n), np.empty(n), np.empty(n)
    acc = np.empty(n)
    A4, A2 = np.empty((n, 4)), np.empty((n, 2))
    c, d = np.empty(4), np.empty(2)
    for w in range(n_windows):
        for s in range(n):
            # the skid-steer kinematics' one home (seed 000 eq. 2), ideal drive chi = 1
            v[s], om[s] = body_rates(vel_l[w, s], vel_r[w, s], track_m, 1.0)
            i_sum[s] = cur_l[w, s] + cur_r[w, s]
            i_diff[s] = cur_r[w, s] - cur_l[w, s]
        if n > 1:                        # numpy.gradient: central inside, one-sided ends
            acc[0] = (v[1] - v[0]) / dt
            acc[n - 1] = (v[n - 1] - v[n - 2]) / dt
            for s in range(1, n - 1):
                acc[s] = (v[s + 1] - v[s - 1]) / (2.0 * dt)
        else:
            acc[0] = 0.0
        sum_i = sum_v = sum_av = sum_o = sum_ao = sum_aa = 0.0
        n_moving = n_turning = 0
        for s in range(n):
            m_v, m_w = np.tanh(abs(v[s]) / v0), np.tanh(abs(om[s]) / w0)
            A4[s, 0], A4[s, 1], A4[s, 2], A4[s, 3] = 1.0, m_v, abs(acc[s]), m_w
            A2[s, 0], A2[s, 1] = np.sign(om[s]) * m_v, om[s]
            sum_i += i_sum[s]
            sum_v += v[s]
            sum_av += abs(v[s])
            sum_o += om[s]
            sum_ao += abs(om[s])
            sum_aa += abs(acc[s])
            n_moving += abs(v[s]) > v0
            n_turning += abs(om[s]) > w0
        e_sum = _ridge_fit(i_sum, A4, ridge, True, c)
        e_diff = _ridge_fit(i_diff, A2, ridge, False, d)
        # mean current while turning / while driving straight, shrunk to the window mean
        # when the window holds (almost) none of that motion (1 sample's weight)
        mean_all = sum_i / n
        wt = wi_t = ws = wi_s = 0.0
        for s in range(n):
            w_turn, w_straight = A4[s, 3], A4[s, 1] * (1.0 - A4[s, 3])
            wt += w_turn
            wi_t += w_turn * i_sum[s]
            ws += w_straight
            wi_s += w_straight * i_sum[s]
        ripple = 0.0
        if n > 2:
            dif = np.empty(n - 1)
            for s in range(n - 1):
                dif[s] = i_sum[s + 1] - i_sum[s]
            ripple = _std(dif, (i_sum[n - 1] - i_sum[0]) / (n - 1))
        q_sum = np.sort(i_sum)
        q_diff = np.sort(np.abs(i_diff))
        o = out[w]
        o[0], o[1], o[2], o[3], o[4] = c[0], c[1], c[2], c[3], e_sum
        o[5], o[6], o[7] = d[0], d[1], e_diff
        o[8] = (wi_t + mean_all) / (wt + 1.0)
        o[9] = (wi_s + mean_all) / (ws + 1.0)
        o[10] = mean_all / max(sum_av / n, v0)
        o[11] = mean_all / max(sum_ao / n, w0)
        o[12], o[13], o[14] = (quantile_sorted(q_sum, 0.1), quantile_sorted(q_sum, 0.5),
                               quantile_sorted(q_sum, 0.9))
        o[15], o[16] = quantile_sorted(q_diff, 0.5), quantile_sorted(q_diff, 0.9)
        o[17] = ripple
        o[18], o[19] = sum_av / n, _std(v, sum_v / n)
        o[20], o[21] = sum_ao / n, _std(om, sum_o / n)
        o[22] = sum_aa / n
        o[23], o[24] = n_moving / n, n_turning / n


def physics_features(vel_l: np.ndarray, vel_r: np.ndarray, cur_l: np.ndarray,
                     cur_r: np.ndarray, rate_hz: float, track_m: float = HUSKY_TRACK_M,
                     speed_scale_m_s: float = 0.05, yaw_scale_rad_s: float = 0.1,
                     ridge: float = 1e-3) -> np.ndarray:
    """Physics features of wheel windows (see module docstring), one time scale.

    One compiled loop over the windows (numba): the ~40 NumPy calls the features would take
    cost ~1 ms for a single window, most of a wheel-only streaming decision
    (``benchmarks/bench_serving.py --kind wheels``). The acceleration is
    :func:`numpy.gradient`'s (central differences inside, one-sided at the ends), the
    quantiles :func:`numpy.quantile`'s (``linear``), the spreads population standard
    deviations; the fits solve the ridge normal equations ``(A^T A + ridge n I) b = A^T y``
    with :func:`numpy.linalg.solve`, the current sum's on regressors and current centred on
    their window means with the no-load term ``c0 = mean(I_L + I_R) - mean(A) b`` recovered
    unpenalised (scikit-learn's ``Ridge(fit_intercept=True)``; the equality with a NumPy
    formulation is tested, ``tests/serving/test_wheel_physics.py``).

    Parameters
    ----------
    vel_l, vel_r : numpy.ndarray
        ``(n_windows, n_samples)`` wheel speeds, m/s.
    cur_l, cur_r : numpy.ndarray
        ``(n_windows, n_samples)`` motor currents, A.
    rate_hz : float
        Sampling rate, Hz (> 0).
    track_m : float
        Track width B, m (Husky A200 by default; > 0).
    speed_scale_m_s : float
        Speed scale ``v0`` of ``m_v``; at or below it the robot counts as standing
        (``moving__fraction`` counts ``|v| > v0``), m/s (> 0).
    yaw_scale_rad_s : float
        Yaw-rate scale ``w0`` of ``m_w``; at or below it the robot counts as going straight
        (``turning__fraction`` counts ``|omega| > w0``), rad/s (> 0).
    ridge : float
        Ridge weight of the fits (per sample, squared regressor units; > 0, so that a
        window without motion still has one solution); the no-load term is not penalised.

    Returns
    -------
    numpy.ndarray
        ``(n_windows, len(PHYSICS_FEATURES))``.

    Raises
    ------
    ConfigError
        A rate, track, scale or ridge that is not a real number (text, a bool), or not
        finite and > 0.
    DataFormatError
        An input that holds booleans (a mask) or does not convert to real numbers (text);
        the message names it.
    ShapeError
        The four inputs are not 2-D arrays of one shape with at least one sample.
    NonFiniteInputError
        An input holds NaN or inf (the message names it and the first windows).
    """
    # (True passed a range check as 1, text failed inside NumPy's isfinite)
    config_positive("physics_features", rate_hz=rate_hz, track_m=track_m,
                    speed_scale_m_s=speed_scale_m_s, yaw_scale_rad_s=yaw_scale_rad_s,
                    ridge=ridge)
    inputs = {"vel_l": vel_l, "vel_r": vel_r, "cur_l": cur_l, "cur_r": cur_r}
    # (a mask passed as a speed was read as 1 m/s)
    arrays = [np.ascontiguousarray(a) for a in real_arrays("physics_features", **inputs)]
    shape = arrays[0].shape
    if len(shape) != 2 or shape[1] < 1 or any(a.shape != shape for a in arrays):
        raise ShapeError("physics_features: vel_l, vel_r, cur_l, cur_r must be "
                         f"(n_windows, n_samples >= 1) arrays of one shape, got "
                         f"{[a.shape for a in arrays]}")
    out = np.empty((shape[0], len(PHYSICS_FEATURES)))
    try:
        _physics_kernel(*arrays, 1.0 / float(rate_hz), float(track_m),
                        float(speed_scale_m_s), float(yaw_scale_rad_s), float(ridge), out)
    except np.linalg.LinAlgError:
        # the ridge fits' solve refuses a NaN or inf (checked here, off the hot path)
        for name, a in zip(("vel_l", "vel_r", "cur_l", "cur_r"), arrays):
            bad = ~np.isfinite(a)
            if bad.any():
                raise NonFiniteInputError(
                    f"physics_features: {name} holds {int(bad.sum())} non-finite "
                    f"sample{'s' if bad.sum() > 1 else ''} "
                    f"({first_items(np.unique(np.nonzero(bad)[0]), word='window')})") from None
        raise
    return out


class WheelPhysicsFeatures(TransformerMixin, BaseEstimator):
    """Wheel-only physics features at two time scales (stateless transformer).

    Parameters
    ----------
    channels : tuple of str
        Channel order of axis 1 of the windows; must include ``vel_l, vel_r, cur_l, cur_r``.
    rate_hz : float
        Sampling rate of the windows, Hz; default the aligned clock's
        (:data:`terrain.io.align.DEFAULT_RATE_HZ`, 50 Hz), at which
        :func:`features.windows.make_windows` cuts by default.
    short_s : float or None
        Length of the second, recent time scale, s; ``None``: whole window only. Also
        whole window only (no ``__last...s`` names) where it rounds to fewer than 3
        samples (too few for the fits) or to the whole window or more (the same features
        twice; also a length whose sample count overflows a float, 1e308 s at 100 Hz).
    track_m : float
        Track width B, m.
    ridge : float
        Ridge weight of the current-balance fits (> 0).

    Attributes
    ----------
    feature_names_out_ : numpy.ndarray of str
        Output names, ``<name>`` (whole window) then ``<name>__last<short_s>s``.
    n_features_in_ : int
        Channels of the windows seen in ``fit`` (``X.shape[1]``, ``len(channels)``), as
        scikit-learn's ``Pipeline`` and ``FeatureUnion`` read it from their first step.
    """

    def __init__(self, channels: tuple[str, ...] = WHEEL_CHANNELS,
                 rate_hz: float = DEFAULT_RATE_HZ,
                 short_s: float | None = 2.0, track_m: float = HUSKY_TRACK_M,
                 ridge: float = 1e-3) -> None:
        self.channels = channels
        self.rate_hz = rate_hz
        self.short_s = short_s
        self.track_m = track_m
        self.ridge = ridge

    def _scales(self, n_samples: int) -> list[tuple[str, int]]:
        scales = [("", n_samples)]
        count = None if self.short_s is None else self.short_s * self.rate_hz
        # (a count past a float, 1e308 s at 100 Hz, is past any window: round() overflowed)
        if count is not None and np.isfinite(count):
            m = int(round(count))
            if 3 <= m < n_samples:
                scales.append((f"__last{self.short_s:g}s", m))
        return scales

    def _layout(self) -> tuple:
        """Every setting: fit checked them and fixed the time scales and names from them."""
        return (("channels", tuple(self.channels)), ("rate_hz", self.rate_hz),
                ("short_s", self.short_s), ("track_m", self.track_m), ("ridge", self.ridge))

    def fit(self, X: np.ndarray, y: np.ndarray | None = None) -> "WheelPhysicsFeatures":
        """Check the channels and fix the output names. Returns self.

        Parameters
        ----------
        X : numpy.ndarray
            ``(n_windows, n_channels, n_samples)`` windows.
        y : ignored
            Present for the scikit-learn transformer protocol.

        Returns
        -------
        WheelPhysicsFeatures
            ``self``, with ``feature_names_out_``, ``n_features_in_`` (channels),
            ``n_samples_in_`` and ``layout_`` (the settings checked, which fixed the names)
            set.

        Raises
        ------
        ConfigError
            A wheel channel is missing from ``channels`` or named twice there (the
            channels are read by position), ``rate_hz``, ``track_m`` or ``ridge`` not a
            finite number > 0 (text and bools refused), or ``short_s`` not a finite number
            (text, a bool, NaN, inf) or None.
        ValueError
            ``X`` not of real numbers (booleans, text, complex), not of 3 dimensions, of
            another number of channels than ``channels``, of 0 windows or of windows of 0
            samples.
        """
        missing = [c for c in WHEEL_CHANNELS if c not in self.channels]
        if missing:
            raise ConfigError(f"WheelPhysicsFeatures needs channels {missing}")
        twice = duplicated(self.channels)
        if twice:        # the first of two was read, the other ignored without a word
            raise ConfigError(f"WheelPhysicsFeatures: channels {twice} given twice")
        # they set the scales' sample counts and names (True was a 1 s scale, "__last1s")
        config_numbers("WheelPhysicsFeatures", optional=("short_s",), rate_hz=self.rate_hz,
                       short_s=self.short_s)
        # (NaN or inf failed in int(round(...)) naming no field; a rate, track or ridge
        # <= 0 passed fit and was refused only at transform, by physics_features)
        config_positive("WheelPhysicsFeatures", rate_hz=self.rate_hz, track_m=self.track_m,
                        ridge=self.ridge)
        if self.short_s is not None and not np.isfinite(self.short_s):
            raise ConfigError(f"WheelPhysicsFeatures.short_s must be a finite number of "
                              f"seconds or None, got {self.short_s!r}")
        X = as_windows(X, self.channels)
        if X.shape[2] < 1:       # (names fixed, then transform failed in physics_features)
            raise ValueError(f"windows need at least 1 sample, got X of shape {X.shape}")
        self.feature_names_out_ = np.asarray(
            [f"{f}{suffix}" for suffix, _ in self._scales(X.shape[2])
             for f in PHYSICS_FEATURES], dtype=object)
        self.n_features_in_ = X.shape[1]
        self.n_samples_in_ = X.shape[2]
        self.layout_ = self._layout()
        return self

    def transform(self, X: np.ndarray) -> np.ndarray:
        """Features of each window.

        Parameters
        ----------
        X : numpy.ndarray
            ``(n_windows, n_channels, n_samples)``; SI units.

        Returns
        -------
        numpy.ndarray
            ``(n_windows, n_features)``.

        Raises
        ------
        ValueError
            ``X`` not of real numbers (booleans, text, complex), of another number of
            channels than ``channels`` or another window length than at fit, of 0 windows,
            or non-finite.
        ConfigError
            A non-positive or non-finite ``rate_hz``, ``track_m`` or ``ridge``.
        sklearn.exceptions.NotFittedError
            ``fit`` has not been called, or a setting was changed since (``set_params``):
            fit checked the settings and fixed the time scales and names from them.
        """
        check_is_fitted(self, "feature_names_out_")
        refuse_changed_layout(self)
        X = as_windows(X, self.channels)
        if X.shape[2] != self.n_samples_in_:
            raise ValueError(f"expected windows of {self.n_samples_in_} samples, got {X.shape}")
        refuse_non_finite(X, self.channels)
        idx = [list(self.channels).index(c) for c in WHEEL_CHANNELS]
        parts = [physics_features(*(X[:, i, -m:] for i in idx), self.rate_hz, self.track_m,
                                  ridge=self.ridge)
                 for _, m in self._scales(X.shape[2])]
        return np.concatenate(parts, axis=1)

    def get_feature_names_out(self, input_features=None) -> np.ndarray:
        """Names of the output columns.

        Parameters
        ----------
        input_features : ignored
        """
        check_is_fitted(self, "feature_names_out_")
        return self.feature_names_out_.copy()
