"""Review (feat9) of the feature calculators, the scipy reference and the windowing:
properties over random windows and tests for surviving hand mutants."""

from __future__ import annotations

import numpy as np
import pytest

from features.reference import reference_features
from features.transformers import WindowFeatures

_CHANNELS = ("ax", "az", "wz", "cur_l", "vel_l", "yaw_rate_wheels")


def _windows(rng, n_windows, n_samples, dtype=float):
    """Random windows of :data:`_CHANNELS` near their physical levels (az about 9.81 m/s^2,
    a current of 5 A, 0.5 m/s), some channels constant."""
    level = np.array([0.0, 9.81, 0.0, 5.0, 0.5, 0.0])[None, :, None]
    spread = np.array([0.3, 0.05, 0.2, 1.0, 0.05, 0.1])[None, :, None]
    X = level + spread * rng.standard_normal((n_windows, len(_CHANNELS), n_samples))
    X[0, 1] = 9.81                   # a constant window of az
    X[-1, 2] = 0.0                   # and one of wz
    return X.astype(dtype)


@pytest.mark.parametrize("rate_hz", [100.0, 50.0, 6.5])
@pytest.mark.parametrize("n_samples", [2, 3, 4, 5, 8, 11, 17, 64, 170])
def test_window_features_equal_the_scipy_reference_over_random_windows(n_samples, rate_hz):
    """Every column of WindowFeatures (statistics, band powers on the rate's frequency axis,
    cross terms) equals the scipy reference, for very short windows, odd and even lengths,
    the 100 Hz IMU and 6.5 Hz wheel rates of BorealTC, and constant channels (skewness and
    kurtosis 0, the reference's rule)."""
    rng = np.random.default_rng(n_samples)
    X = _windows(rng, 4, n_samples)
    got = WindowFeatures(_CHANNELS, rate_hz).fit_transform(X)
    want = reference_features(X, _CHANNELS, rate_hz)
    np.testing.assert_allclose(got, want, rtol=1e-9, atol=1e-12)
    names = list(WindowFeatures(_CHANNELS, rate_hz).fit(X).get_feature_names_out())
    assert got[0, names.index("az__skewness")] == 0.0
    assert got[0, names.index("az__kurtosis")] == 0.0
    assert got[0, names.index("az__std")] == pytest.approx(0.0, abs=1e-12)


@pytest.mark.parametrize("n_samples", [3, 8, 170])
def test_the_reference_of_float32_windows_is_computed_in_float64(n_samples):
    """float32 windows (a logger's dtype): WindowFeatures reads them as float64, the
    reference computed its moments and periodogram in float32, so the two differed by up
    to 1.6 % (the skewness of a 9.81 m/s^2 channel with 0.01 m/s^2 noise) and the
    reference returned float32 rows; now both read float64 and agree to 1e-9."""
    rng = np.random.default_rng(7)
    X = _windows(rng, 3, n_samples, dtype=np.float32)
    X[1, 1] = 9.81 + 0.01 * rng.standard_normal(n_samples)
    want = WindowFeatures(_CHANNELS, 100.0).fit_transform(X)
    got = reference_features(X, _CHANNELS, 100.0)
    assert got.dtype == np.float64
    np.testing.assert_allclose(got, want, rtol=1e-9, atol=1e-12)
    np.testing.assert_allclose(want, WindowFeatures(_CHANNELS, 100.0).fit_transform(
        X.astype(float)), rtol=0, atol=0)


def test_every_column_is_the_feature_its_name_says():
    """Names and values in one order: each ``<channel>__<stat>`` column is that statistic
    of that channel (scipy / NumPy), each ``<imu>__band_<lo>_<hi>hz`` column the log10 mean
    periodogram density of that channel's bins in [lo, hi) on the rate's frequency axis
    (0.5 Hz bins of a 200-sample window at 100 Hz), and the cross terms their formulas. The
    scipy reference builds its rows in the same order as the transformer's values, so it
    cannot tell a name list in another order; this reads each column by its name."""
    from scipy import signal, stats as sps
    rng = np.random.default_rng(11)
    X = _windows(rng, 3, 200)
    fx = WindowFeatures(_CHANNELS, 100.0).fit(X)
    F = fx.transform(X)
    idx = {c: i for i, c in enumerate(_CHANNELS)}
    stat = {"mean": np.mean, "std": np.std, "rms": lambda v: np.sqrt(np.mean(v ** 2)),
            "min": np.min, "max": np.max, "mean_abs_diff": lambda v: np.mean(np.abs(np.diff(v))),
            "skewness": lambda v: sps.skew(v) if np.std(v) > 1e-6 else 0.0,
            "kurtosis": lambda v: sps.kurtosis(v) if np.std(v) > 1e-6 else 0.0}
    names = list(fx.get_feature_names_out())
    assert len(names) == F.shape[1] == 6 * 8 + 3 * 20 + 2
    for j, name in enumerate(names):
        sig, feat = name.split("__", 1)
        for w in range(len(X)):
            x = X[w, idx[sig]] if sig in idx else None
            if feat in stat:
                want = stat[feat](x)
            elif feat.startswith("band_"):
                lo, hi = (float(v.replace("p", ".")) for v in feat[5:-2].split("_"))
                f, p = signal.periodogram(x, fs=100.0, window="hann", detrend="constant")
                assert f[-1] == 50.0 and f[1] == 0.5
                want = np.log10(p[(f >= lo) & (f < hi)].mean() + 1e-12)
            elif feat == "per_speed":
                want = x.mean() / max(np.abs(X[w, idx["vel_l"]]).mean(), fx.min_speed_m_s)
            else:
                assert name == "wz__gain_on_yaw_rate_wheels"
                u = X[w, idx["yaw_rate_wheels"]]
                want = np.dot(u, x) / (np.dot(u, u) + len(u) * fx.turn_floor_rad_s ** 2)
            assert F[w, j] == pytest.approx(want, rel=1e-9, abs=1e-12), (name, w)
