"""scikit-learn transformer turning windows into a named feature matrix.

Input ``X`` is ``(n_windows, n_channels, n_samples)`` from :mod:`features.windows` with the
channel order given by the ``channels`` hyperparameter; output is ``(n_windows, n_features)``
with names from :meth:`WindowFeatures.get_feature_names_out`, e.g. ``wz__std``,
``az__band_5_10hz``, ``cur_l__per_speed``.
"""

from __future__ import annotations

import math

import numpy as np
from sklearn.base import BaseEstimator, TransformerMixin
from sklearn.pipeline import FeatureUnion
from sklearn.utils.validation import check_is_fitted

from features import calculators
from features.windows import (ALL_CHANNELS, as_windows, refuse_changed_layout,
                              refuse_non_finite)
from terrain.errors import ConfigError, config_positive, duplicated, first_items
from terrain.io.align import DEFAULT_RATE_HZ
from terrain.run import IMU_CHANNELS

DEFAULT_STATS = tuple(calculators.STATISTICS)

#: Most bands :func:`linear_bands` makes (0.05 Hz bands up to a 500 Hz Nyquist frequency);
#: a width typed in the wrong unit (1e-6 Hz at 50 Hz: 25 million bands, each a feature of
#: every channel) is refused before any is built.
MAX_BANDS = 10_000
#: Bands of :func:`linear_bands` narrower than this are dropped, Hz: the sliver the float
#: edges leave below the Nyquist frequency when it is a multiple of the width.
_NARROWEST_BAND_HZ = 1e-9


def linear_bands(rate_hz: float, band_width_hz: float) -> tuple[tuple[float, float], ...]:
    """Contiguous bands ``[k w, (k+1) w)`` from 0 Hz to the Nyquist frequency ``rate_hz/2``.

    The last band is cut at the Nyquist frequency when ``rate_hz/2`` is not a multiple of
    ``band_width_hz``; bands narrower than 1e-9 Hz are dropped. Each upper edge being
    exclusive, the FFT bin at exactly the Nyquist frequency (that of a window of an even
    number of samples) lies in no band (but where a band holding no bin borrows it as its
    nearest, :func:`features.calculators.band_weights`); every other bin lies in one band.
    A tone at the Nyquist frequency still shows in the last band, through the Hann taper's
    leakage into the bin below (:func:`features.calculators.band_log_power`).

    Parameters
    ----------
    rate_hz : float
        Sampling rate of the windows, Hz.
    band_width_hz : float
        Width ``w`` of each band, Hz.

    Returns
    -------
    tuple of (float, float)
        ``(lower, upper)`` edges of each band, Hz, ascending; lower edge inclusive, upper
        exclusive.

    Raises
    ------
    ConfigError
        ``rate_hz`` or ``band_width_hz`` not a finite number > 0 (a negative width gave no
        band at all), or more than :data:`MAX_BANDS` bands.
    """
    config_positive("linear_bands", rate_hz=rate_hz, band_width_hz=band_width_hz)
    nyquist = rate_hz / 2.0
    # the bands made, the sliver dropped (ceil(nyquist / width) counted it: 374.1 Hz at
    # 0.018705 Hz, exactly MAX_BANDS bands, was 10000.000000000002, so 10001, and refused)
    n_bands = math.ceil((nyquist - _NARROWEST_BAND_HZ) / band_width_hz)
    if n_bands > MAX_BANDS:
        raise ConfigError(f"linear_bands: band_width_hz {band_width_hz:g} Hz cuts 0-{nyquist:g} "
                          f"Hz into {n_bands} bands, more than {MAX_BANDS} (each is a feature "
                          "of every channel); is the width in Hz?")
    edges = np.append(np.arange(0.0, nyquist, band_width_hz), nyquist)
    return tuple((float(a), float(b)) for a, b in zip(edges[:-1], edges[1:])
                 if b - a > _NARROWEST_BAND_HZ)


def _band_name(lo: float, hi: float) -> str:
    fmt = (lambda v: f"{v:g}".replace(".", "p"))
    return f"band_{fmt(lo)}_{fmt(hi)}hz"


class WindowFeatures(TransformerMixin, BaseEstimator):
    """Per-window time-domain statistics, IMU band powers and speed-normalised wheel terms.

    Stateless: ``fit`` only checks the input and fixes the output names, so features may be
    computed once for a whole dataset before cross-validation without leakage.

    Parameters
    ----------
    channels : tuple of str
        Names of the input channels, in the order of axis 1 of ``X``.
    rate_hz : float
        Sampling rate of the windows, Hz; default the aligned clock's
        (:data:`terrain.io.align.DEFAULT_RATE_HZ`, 50 Hz).
    stats : tuple of str
        Statistics from :data:`features.calculators.STATISTICS` computed for every channel.
    bands_hz : tuple of (float, float) or None
        Spectral bands, Hz, computed for the IMU channels present (log10 PSD). ``None``:
        contiguous bands of ``band_width_hz`` up to the Nyquist frequency. Fine linear bands
        up to Nyquist matter: on BorealTC, 2.5 Hz bands up to 50 Hz raise run-grouped
        accuracy from 0.81 (five log-spaced bands) to 0.86 (measured, 3 seeds).
    band_width_hz : float
        Width of the default bands, Hz.
    min_speed_m_s : float
        Speed floor of the current-per-speed features, m/s (finite, > 0).
    turn_floor_rad_s : float
        Ridge floor of the yaw-rate gain feature (``wz`` on ``yaw_rate_wheels``), rad/s
        (finite, > 0).

    Attributes
    ----------
    feature_names_out_ : numpy.ndarray of str
        Output column names.
    n_features_in_ : int
        Channels of the windows seen in ``fit`` (``X.shape[1]``, ``len(channels)``), as
        scikit-learn's ``Pipeline`` and ``FeatureUnion`` read it from their first step.
    """

    def __init__(self, channels: tuple[str, ...] = ALL_CHANNELS,
                 rate_hz: float = DEFAULT_RATE_HZ,
                 stats: tuple[str, ...] = DEFAULT_STATS,
                 bands_hz: tuple[tuple[float, float], ...] | None = None,
                 band_width_hz: float = 2.5,
                 min_speed_m_s: float = 0.05, turn_floor_rad_s: float = 0.05) -> None:
        self.channels = channels
        self.rate_hz = rate_hz
        self.stats = stats
        self.bands_hz = bands_hz
        self.band_width_hz = band_width_hz
        self.min_speed_m_s = min_speed_m_s
        self.turn_floor_rad_s = turn_floor_rad_s

    def _check(self, X: np.ndarray) -> np.ndarray:
        X = as_windows(X, self.channels)     # (0 windows: the reshape would fail in NumPy)
        if X.shape[2] < 2:       # (mean_abs_diff of one sample is NaN)
            raise ValueError(f"windows need at least 2 samples, got X of shape {X.shape}")
        refuse_non_finite(X, self.channels)
        return X

    def _layout(self) -> tuple:
        """Every setting, comparably: fit checked them and fixed the columns from them."""
        bands = None if self.bands_hz is None else tuple(tuple(b) for b in self.bands_hz)
        return (("channels", tuple(self.channels)), ("stats", tuple(self.stats)),
                ("rate_hz", self.rate_hz), ("bands_hz", bands),
                ("band_width_hz", self.band_width_hz), ("min_speed_m_s", self.min_speed_m_s),
                ("turn_floor_rad_s", self.turn_floor_rad_s))

    def _cross_terms(self) -> list[tuple[str, tuple[str, str]]]:
        ch = set(self.channels)
        terms = [(f"{c}__per_speed", (c, v)) for c, v in (("cur_l", "vel_l"), ("cur_r", "vel_r"))
                 if {c, v} <= ch]
        if {"wz", "yaw_rate_wheels"} <= ch:
            terms.append(("wz__gain_on_yaw_rate_wheels", ("wz", "yaw_rate_wheels")))
        return terms

    def fit(self, X: np.ndarray, y: np.ndarray | None = None) -> "WindowFeatures":
        """Check ``X`` and fix the output names and bands.

        Parameters
        ----------
        X : numpy.ndarray
            ``(n_windows, n_channels, n_samples)`` windows, channels in the order of
            ``channels``, each in its channel's SI unit.
        y : numpy.ndarray or None
            Ignored (scikit-learn API); ``(n_windows,)`` labels when given.

        Returns
        -------
        WindowFeatures
            ``self``, with ``feature_names_out_``, ``bands_`` (Hz), ``n_features_in_``
            (channels), ``n_samples_in_``, the FFT helpers ``taper_`` / ``band_weights_``
            of that window length and ``layout_`` (the settings they were made with) set.

        Raises
        ------
        ConfigError
            ``channels`` or ``stats`` given as one text (or None) instead of a sequence
            of names, an unknown statistic name, a ``min_speed_m_s`` or
            ``turn_floor_rad_s`` that is not a finite number > 0, a ``rate_hz`` or
            ``band_width_hz`` :func:`linear_bands` refuses, or a band of ``bands_hz`` that
            :func:`features.calculators.band_weights` refuses (not finite, inverted, or
            outside 0 Hz to the Nyquist frequency), or a feature name that occurs twice (a
            repeated channel or statistic, or two bands whose names agree).
        ValueError
            ``X`` not of real numbers (booleans, text, complex), of the wrong shape, of 0
            windows, of windows of fewer than 2 samples, or non-finite.
        """
        for field, value in (("channels", self.channels), ("stats", self.stats)):
            if isinstance(value, str):      # ("ax" was read as the channels 'a' and 'x')
                raise ConfigError(f"WindowFeatures.{field} must be a sequence of names, got "
                                  f"the text {value!r}; one name is written ({value!r},)")
            if not hasattr(value, "__iter__") or not hasattr(value, "__len__"):
                # (None was a bare TypeError of len() or of the iteration)
                raise ConfigError(f"WindowFeatures.{field} must be a sequence of names, got "
                                  f"{value!r}")
        unknown = [s for s in self.stats if s not in calculators.STATISTICS]
        if unknown:
            raise ConfigError(f"unknown statistics {unknown}; valid: "
                              f"{list(calculators.STATISTICS)}")
        # the floors keep the cross terms of a standing, straight window finite
        config_positive("WindowFeatures", min_speed_m_s=self.min_speed_m_s,
                        turn_floor_rad_s=self.turn_floor_rad_s)
        X = self._check(X)
        names = [f"{c}__{s}" for c in self.channels for s in self.stats]
        # every check before the first attribute is set: a refused (re)fit leaves no mix of
        # new names and old band weights behind
        bands = (tuple(self.bands_hz) if self.bands_hz is not None
                 else linear_bands(self.rate_hz, self.band_width_hz))
        # (before the names: a band of text or three edges failed in their formatting)
        weights = calculators.band_weights(X.shape[2], self.rate_hz, bands)
        names += [f"{c}__{_band_name(lo, hi)}" for c in self.channels if c in IMU_CHANNELS
                  for lo, hi in bands]
        names += [name for name, _ in self._cross_terms()]
        repeated = duplicated(names)
        if repeated:
            why = [f"{field} {twice} given twice" for field, twice in
                   (("channels", duplicated(self.channels)), ("stats", duplicated(self.stats)))
                   if twice] or ["bands whose edges agree to 6 digits"]
            raise ConfigError(f"WindowFeatures: feature names occur more than once "
                              f"({'; '.join(why)}): {first_items(repeated, word='name')}")
        # weights: constant FFT helpers of this window length (from the settings, not the data)
        self.bands_ = bands
        self.n_features_in_ = X.shape[1]
        self.n_samples_in_ = X.shape[2]
        self.taper_ = calculators.hann_taper(self.n_samples_in_)
        self.band_weights_ = weights
        self.feature_names_out_ = np.asarray(names, dtype=object)
        self.layout_ = self._layout()
        return self

    def transform(self, X: np.ndarray) -> np.ndarray:
        """Features of each window.

        Parameters
        ----------
        X : numpy.ndarray
            ``(n_windows, n_channels, n_samples)`` windows, channels in the order of
            ``channels``, each in its channel's SI unit.

        Returns
        -------
        numpy.ndarray
            ``(n_windows, n_features)``, float64, columns named by
            :meth:`get_feature_names_out`.

        Raises
        ------
        sklearn.exceptions.NotFittedError
            ``fit`` has not been called, or a setting was changed since (``set_params``):
            fit checked the settings and fixed the names of the columns from them.
        ValueError
            ``X`` not of real numbers (booleans, text, complex), of the wrong shape, of 0
            windows, of windows of fewer than 2 samples, or non-finite.
        """
        check_is_fitted(self, "feature_names_out_")
        refuse_changed_layout(self)
        X = self._check(X)
        parts = [calculators.statistics(X, self.stats).reshape(len(X), -1)]
        imu = [i for i, c in enumerate(self.channels) if c in IMU_CHANNELS]
        if imu and self.bands_:
            same_length = X.shape[2] == self.n_samples_in_ and hasattr(self, "taper_")
            bp = calculators.band_log_power(
                X[:, imu], self.rate_hz, self.bands_,
                weights=self.band_weights_ if same_length else None,
                taper=self.taper_ if same_length else None)
            parts.append(bp.reshape(len(X), -1))
        idx = {c: i for i, c in enumerate(self.channels)}
        for name, (a, b) in self._cross_terms():
            if name.endswith("per_speed"):
                col = calculators.per_speed(X[:, idx[a]], X[:, idx[b]], self.min_speed_m_s)
            else:
                col = calculators.regression_gain(X[:, idx[a]], X[:, idx[b]],
                                                  self.turn_floor_rad_s)
            parts.append(col[:, None])
        return np.concatenate(parts, axis=1)

    def get_feature_names_out(self, input_features=None) -> np.ndarray:
        """Names of the output columns (``<signal>__<feature>[__<param>]``)."""
        check_is_fitted(self, "feature_names_out_")
        return self.feature_names_out_.copy()


class SerialFeatureUnion(FeatureUnion):
    """:class:`sklearn.pipeline.FeatureUnion` that transforms its parts one after the other.

    ``FeatureUnion.transform`` dispatches every part through joblib, even with
    ``n_jobs=None``: ~0.3 ms per call on this project's machines, more than the
    wheel-physics features of a single window take (``benchmarks/bench_serving.py --kind
    wheels``). Here, when there is nothing to route (no transform parameters, metadata
    routing off) and ``n_jobs`` asks for no parallelism, the parts are called in order and
    their (weighted) outputs stacked as ``FeatureUnion`` stacks them (each part runs once,
    whatever it returns: dense arrays are stacked directly, pandas or sparse outputs by
    ``FeatureUnion``'s own stacking); otherwise, and for ``fit`` / ``fit_transform``,
    ``FeatureUnion`` runs unchanged. Equality with
    ``FeatureUnion.transform`` is tested (``tests/features/test_transformers.py``).

    Parameters
    ----------
    transformer_list : list of (str, transformer)
        As for ``FeatureUnion``.
    n_jobs : int or None
        As for ``FeatureUnion``.
    transformer_weights : dict or None
        As for ``FeatureUnion``.
    verbose : bool
        As for ``FeatureUnion``.
    verbose_feature_names_out : bool
        As for ``FeatureUnion``.
    """

    def transform(self, X, **params):
        """Transform ``X`` by each part in turn and stack the results.

        Parameters
        ----------
        X : numpy.ndarray
            ``(n_windows, n_channels, n_samples)`` windows.
        **params : dict
            Routed to the parts as by ``FeatureUnion.transform`` (then through joblib).

        Returns
        -------
        numpy.ndarray
            ``(n_windows, sum of the parts' features)`` (a ``pandas.DataFrame`` or a sparse
            matrix where the parts' output is, as ``FeatureUnion`` stacks them).
        """
        from sklearn.utils.metadata_routing import _routing_enabled

        if params or _routing_enabled() or self.n_jobs not in (None, 1):
            return super().transform(X, **params)
        # FeatureUnion's own iteration ("drop" skipped, "passthrough" as identity, weights)
        Xs = [part.transform(X) if weight is None else part.transform(X) * weight
              for _, part, weight in self._iter()]
        if not Xs:
            return np.zeros((len(X), 0))
        if all(isinstance(Xt, np.ndarray) and Xt.ndim == 2 for Xt in Xs):
            return np.hstack(Xs)
        return self._hstack(Xs)   # FeatureUnion's stacking: pandas or sparse output
