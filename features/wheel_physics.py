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
each window is fitted by ridge least squares to two current balances::

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

import numpy as np
from sklearn.base import BaseEstimator, TransformerMixin
from sklearn.utils.validation import check_is_fitted

from features.windows import HUSKY_TRACK_M
from terrain.errors import ConfigError
from terrain.run import WHEEL_CHANNELS

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


def ridge_fit(y: np.ndarray, A: np.ndarray, ridge: float) -> tuple[np.ndarray, np.ndarray]:
    """Batched ridge least squares ``y ~ A b`` per window.

    Parameters
    ----------
    y : numpy.ndarray
        ``(n_windows, n_samples)`` responses.
    A : numpy.ndarray
        ``(n_windows, n_samples, n_terms)`` regressors.
    ridge : float
        Ridge weight per sample (>= 0), in squared regressor units.

    Returns
    -------
    coef : numpy.ndarray
        ``(n_windows, n_terms)``.
    resid_std : numpy.ndarray
        ``(n_windows,)`` standard deviation of the residual.
    """
    n = A.shape[1]
    G = np.einsum("wsi,wsj->wij", A, A) + ridge * n * np.eye(A.shape[2])[None]
    coef = np.linalg.solve(G, np.einsum("wsi,ws->wi", A, y)[..., None])[..., 0]
    resid = y - np.einsum("wsi,wi->ws", A, coef)
    return coef, resid.std(axis=1)


def physics_features(vel_l: np.ndarray, vel_r: np.ndarray, cur_l: np.ndarray,
                     cur_r: np.ndarray, rate_hz: float, track_m: float = HUSKY_TRACK_M,
                     speed_scale_m_s: float = 0.05, yaw_scale_rad_s: float = 0.1,
                     ridge: float = 1e-3) -> np.ndarray:
    """Physics features of wheel windows (see module docstring), one time scale.

    Parameters
    ----------
    vel_l, vel_r : numpy.ndarray
        ``(n_windows, n_samples)`` wheel speeds, m/s.
    cur_l, cur_r : numpy.ndarray
        ``(n_windows, n_samples)`` motor currents, A.
    rate_hz : float
        Sampling rate, Hz.
    track_m : float
        Track width B, m (Husky A200 by default).
    speed_scale_m_s : float
        Speed scale ``v0`` of ``m_v``; below it the robot counts as standing, m/s.
    yaw_scale_rad_s : float
        Yaw-rate scale ``w0`` of ``m_w``; below it the robot counts as going straight,
        rad/s.
    ridge : float
        Ridge weight of the fits (per sample, squared regressor units).

    Returns
    -------
    numpy.ndarray
        ``(n_windows, len(PHYSICS_FEATURES))``.
    """
    v = 0.5 * (vel_l + vel_r)
    omega = (vel_r - vel_l) / track_m
    i_sum, i_diff = cur_l + cur_r, cur_r - cur_l
    acc = np.gradient(v, 1.0 / rate_hz, axis=1) if v.shape[1] > 1 else np.zeros_like(v)
    abs_v, abs_o = np.abs(v), np.abs(omega)
    m_v, m_w = np.tanh(abs_v / speed_scale_m_s), np.tanh(abs_o / yaw_scale_rad_s)
    c, e_sum = ridge_fit(i_sum, np.stack([np.ones_like(v), m_v, np.abs(acc), m_w], axis=-1),
                         ridge)
    d, e_diff = ridge_fit(i_diff, np.stack([np.sign(omega) * m_v, omega], axis=-1), ridge)
    # mean current while turning / while driving straight, shrunk to the window mean when
    # the window holds (almost) none of that motion (1 sample's weight)
    w_turn, w_straight = m_w, m_v * (1.0 - m_w)
    mean_all = i_sum.mean(1)
    turning = ((w_turn * i_sum).sum(1) + mean_all) / (w_turn.sum(1) + 1.0)
    straight = ((w_straight * i_sum).sum(1) + mean_all) / (w_straight.sum(1) + 1.0)
    per_speed = mean_all / np.maximum(abs_v.mean(1), speed_scale_m_s)
    per_yaw = mean_all / np.maximum(abs_o.mean(1), yaw_scale_rad_s)
    q_sum = np.quantile(i_sum, [0.1, 0.5, 0.9], axis=1)
    q_diff = np.quantile(np.abs(i_diff), [0.5, 0.9], axis=1)
    ripple = np.diff(i_sum, axis=1).std(axis=1) if i_sum.shape[1] > 2 else np.zeros(len(v))
    cols = [c[:, 0], c[:, 1], c[:, 2], c[:, 3], e_sum, d[:, 0], d[:, 1], e_diff, turning,
            straight, per_speed, per_yaw, q_sum[0], q_sum[1], q_sum[2], q_diff[0], q_diff[1],
            ripple, abs_v.mean(1), v.std(1), abs_o.mean(1), omega.std(1), np.abs(acc).mean(1),
            (abs_v > speed_scale_m_s).mean(1), (abs_o > yaw_scale_rad_s).mean(1)]
    return np.stack(cols, axis=1)


class WheelPhysicsFeatures(TransformerMixin, BaseEstimator):
    """Wheel-only physics features at two time scales (stateless transformer).

    Parameters
    ----------
    channels : tuple of str
        Channel order of axis 1 of the windows; must include ``vel_l, vel_r, cur_l, cur_r``.
    rate_hz : float
        Sampling rate of the windows, Hz.
    short_s : float or None
        Length of the second, recent time scale, s; ``None``: whole window only.
    track_m : float
        Track width B, m.
    ridge : float
        Ridge weight of the current-balance fits.

    Attributes
    ----------
    feature_names_out_ : numpy.ndarray of str
        Output names, ``<name>`` (whole window) then ``<name>__last<short_s>s``.
    """

    def __init__(self, channels: tuple[str, ...] = WHEEL_CHANNELS, rate_hz: float = 10.0,
                 short_s: float | None = 2.0, track_m: float = HUSKY_TRACK_M,
                 ridge: float = 1e-3) -> None:
        self.channels = channels
        self.rate_hz = rate_hz
        self.short_s = short_s
        self.track_m = track_m
        self.ridge = ridge

    def _scales(self, n_samples: int) -> list[tuple[str, int]]:
        scales = [("", n_samples)]
        if self.short_s is not None:
            m = int(round(self.short_s * self.rate_hz))
            if 3 <= m < n_samples:
                scales.append((f"__last{self.short_s:g}s", m))
        return scales

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
            ``self``, with ``feature_names_out_`` and ``n_samples_in_`` set.

        Raises
        ------
        ConfigError
            A wheel channel is missing from ``channels``.
        """
        missing = [c for c in WHEEL_CHANNELS if c not in self.channels]
        if missing:
            raise ConfigError(f"WheelPhysicsFeatures needs channels {missing}")
        X = np.asarray(X, dtype=float)
        self.feature_names_out_ = np.asarray(
            [f"{f}{suffix}" for suffix, _ in self._scales(X.shape[2])
             for f in PHYSICS_FEATURES], dtype=object)
        self.n_samples_in_ = X.shape[2]
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
            ``X`` of another window length than at fit, or non-finite.
        """
        check_is_fitted(self, "feature_names_out_")
        X = np.asarray(X, dtype=float)
        if X.ndim != 3 or X.shape[2] != self.n_samples_in_:
            raise ValueError(f"expected windows of {self.n_samples_in_} samples, got {X.shape}")
        if not np.isfinite(X).all():
            raise ValueError("X contains NaN or inf")
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
