"""WindowFeatures: named columns, shape checks, sklearn API, real shipped windows."""

from __future__ import annotations

import re

import numpy as np
import pytest
from sklearn.base import clone
from sklearn.exceptions import NotFittedError

from features import calculators
from features.transformers import DEFAULT_STATS, WindowFeatures, _band_name, linear_bands
from features.windows import ALL_CHANNELS, WindowConfig, make_windows
from terrain.errors import ConfigError

NAME_RE = re.compile(r"^[a-z][a-z0-9_]*?__[a-z0-9_]+$")
CHANNELS = ("wz", "vel_l", "cur_l")


def _windows(n=6, channels=CHANNELS, samples=100, seed=0):
    rng = np.random.default_rng(seed)
    X = rng.standard_normal((n, len(channels), samples))
    X[:, list(channels).index("vel_l") if "vel_l" in channels else 0] += 0.5
    return X


def test_feature_names_follow_convention_and_match_columns():
    X = _windows()
    fx = WindowFeatures(channels=CHANNELS, rate_hz=50.0)
    F = fx.fit_transform(X)
    names = list(fx.get_feature_names_out())
    assert F.shape == (len(X), len(names))
    assert len(set(names)) == len(names)
    for name in names:
        assert NAME_RE.match(name), name
        assert name.split("__")[0] in CHANNELS, name
    bands = linear_bands(50.0, 2.5)
    expected = ([f"{c}__{s}" for c in CHANNELS for s in DEFAULT_STATS]
                + [f"wz__{_band_name(lo, hi)}" for lo, hi in bands]   # IMU channels only
                + ["cur_l__per_speed"])                                # needs cur_l and vel_l
    assert names == expected


def test_columns_hold_what_their_names_say():
    X = _windows()
    fx = WindowFeatures(channels=CHANNELS, rate_hz=50.0, min_speed_m_s=0.05)
    F = fx.fit_transform(X)
    col = {n: F[:, i] for i, n in enumerate(fx.get_feature_names_out())}
    np.testing.assert_allclose(col["wz__mean"], X[:, 0].mean(axis=1))
    np.testing.assert_allclose(col["cur_l__max"], X[:, 2].max(axis=1))
    np.testing.assert_allclose(col["vel_l__kurtosis"], calculators.kurtosis(X[:, 1]))
    np.testing.assert_allclose(col["cur_l__per_speed"],
                               calculators.per_speed(X[:, 2], X[:, 1], 0.05))
    bp = calculators.band_log_power(X[:, :1], 50.0, ((5.0, 7.5),))[:, 0, 0]
    np.testing.assert_allclose(col["wz__band_5_7p5hz"], bp)


def test_cross_terms_use_their_own_floors():
    """``min_speed_m_s`` floors the current-per-speed terms and ``turn_floor_rad_s`` the
    yaw-rate gain, each its own (their defaults are both 0.05, so a swap showed nowhere)."""
    n = 100
    t = np.arange(n) / 50.0
    x = 0.03 * np.sin(2 * np.pi * t)                      # barely turning, rad/s
    window = np.stack([x / 1.4, np.full(n, 4.0), np.full(n, 0.1), x])[None]
    fx = WindowFeatures(channels=("wz", "cur_l", "vel_l", "yaw_rate_wheels"), rate_hz=50.0,
                        stats=(), bands_hz=(), min_speed_m_s=0.5, turn_floor_rad_s=0.02)
    F = fx.fit_transform(window)
    col = dict(zip(fx.get_feature_names_out(), F[0]))
    assert col["cur_l__per_speed"] == pytest.approx(4.0 / 0.5, rel=1e-12)
    gain = (x @ (x / 1.4)) / (x @ x + n * 0.02 ** 2)
    assert col["wz__gain_on_yaw_rate_wheels"] == pytest.approx(gain, rel=1e-12)
    assert 0.2 < gain < 0.6            # the floor matters here: 1 / 1.4 without it


def test_all_channels_include_both_cross_terms():
    fx = WindowFeatures(channels=ALL_CHANNELS, rate_hz=100.0).fit(
        np.ones((2, len(ALL_CHANNELS), 200)))
    names = list(fx.get_feature_names_out())
    assert {"cur_l__per_speed", "cur_r__per_speed", "wz__gain_on_yaw_rate_wheels"} <= set(names)
    n_bands = len(linear_bands(100.0, 2.5))
    assert n_bands == 20
    assert len(names) == len(ALL_CHANNELS) * len(DEFAULT_STATS) + 6 * n_bands + 3


def test_band_names_and_edges():
    assert _band_name(0.0, 2.5) == "band_0_2p5hz"
    assert _band_name(2.5, 5.0) == "band_2p5_5hz"
    assert _band_name(22.5, 25.0) == "band_22p5_25hz"
    bands = linear_bands(50.0, 2.5)
    assert len(bands) == 10 and bands[0] == (0.0, 2.5) and bands[-1] == (22.5, 25.0)
    assert all(a[1] == b[0] for a, b in zip(bands, bands[1:]))  # contiguous
    assert linear_bands(50.0, 3.0)[-1] == (24.0, 25.0)           # last band ends at Nyquist
    fx = WindowFeatures(channels=("ax",), rate_hz=50.0, stats=(),
                        bands_hz=((1.0, 4.0), (4.0, 12.5))).fit(np.ones((1, 1, 50)))
    assert list(fx.get_feature_names_out()) == ["ax__band_1_4hz", "ax__band_4_12p5hz"]


@pytest.mark.parametrize("shape", [(6, 100), (6, 2, 100), (6, 4, 100), (6, 3, 100, 1)])
def test_wrong_shape_raises_value_error(shape):
    fx = WindowFeatures(channels=CHANNELS, rate_hz=50.0)
    with pytest.raises(ValueError, match="shape"):
        fx.fit(np.zeros(shape))
    fitted = WindowFeatures(channels=CHANNELS, rate_hz=50.0).fit(_windows())
    with pytest.raises(ValueError, match="shape"):
        fitted.transform(np.zeros(shape))


def test_non_finite_input_and_unknown_stat_are_rejected():
    X = _windows()
    X[2, 1, 5] = np.nan
    X[4, 1, 0] = X[4, 2, 7] = np.inf
    # the message names the channels and the windows (it said only "X contains NaN or inf")
    with pytest.raises(ValueError, match=r"X contains NaN or inf \(3 values\): 'vel_l' in "
                                         r"windows 2, 4; 'cur_l' in window 4$"):
        WindowFeatures(channels=CHANNELS).fit(X)
    with pytest.raises(ConfigError, match="median"):
        WindowFeatures(channels=CHANNELS, stats=("mean", "median")).fit(_windows())


def test_zero_windows_are_refused_naming_them():
    # WindowFeatures fitted on 0 windows without a word and its transform failed inside
    # NumPy ("cannot reshape array of size 0 into shape (0,newaxis)"), while the wheel
    # physics features returned a (0, 50) matrix: both now refuse 0 windows as scikit-learn
    # refuses 0 samples
    from features.wheel_physics import WheelPhysicsFeatures
    chans = ("vel_l", "vel_r", "cur_l", "cur_r", "wz")
    X = _windows(channels=chans, samples=40)
    for make in (lambda: WindowFeatures(channels=chans, rate_hz=10.0),
                 lambda: WheelPhysicsFeatures(channels=chans, rate_hz=10.0)):
        for call in (lambda: make().fit(X[:0]), lambda: make().fit_transform(X[:0]),
                     lambda: make().fit(X).transform(X[:0])):
            with pytest.raises(ValueError, match=r"0 windows \(X of shape \(0, 5, 40\)\)"):
                call()


def test_transform_before_fit_raises():
    with pytest.raises(NotFittedError):
        WindowFeatures(channels=CHANNELS).transform(_windows())


def test_get_params_set_params_and_clone():
    fx = WindowFeatures(channels=CHANNELS, rate_hz=100.0, stats=("mean", "std"),
                        band_width_hz=5.0)
    params = fx.get_params()
    assert params == {"channels": CHANNELS, "rate_hz": 100.0, "stats": ("mean", "std"),
                      "bands_hz": None, "band_width_hz": 5.0, "min_speed_m_s": 0.05,
                      "turn_floor_rad_s": 0.05}
    fx.fit(_windows(samples=200))
    twin = clone(fx)
    assert twin.get_params() == params
    assert not hasattr(twin, "feature_names_out_")
    twin.set_params(band_width_hz=10.0)
    names = twin.fit(_windows(samples=200)).get_feature_names_out()
    assert sum("__band_" in n for n in names) == 5   # 0-50 Hz in 10 Hz bands, wz only
    assert fx.band_width_hz == 5.0


@pytest.fixture(scope="module")
def shipped_windows(borealtc_runs, vulpi_runs):
    return [make_windows(borealtc_runs, "all", WindowConfig(window_s=2.0, rate_hz=100.0)),
            make_windows(vulpi_runs, "all", WindowConfig(window_s=2.0, rate_hz=50.0))]


@pytest.mark.slow
def test_feature_matrix_on_shipped_windows_is_finite(shipped_windows):
    for ws in shipped_windows:
        fx = WindowFeatures(channels=ws.channels, rate_hz=ws.rate_hz)
        F = fx.fit_transform(ws.X)
        assert F.shape == (len(ws), len(fx.get_feature_names_out()))
        assert len(ws) > 100
        assert np.isfinite(F).all()
        # features vary between windows (no dead column from a wiring mistake)
        assert (F.std(axis=0) > 0).all()


@pytest.mark.slow
def test_shipped_features_match_the_scipy_reference_batch_and_single(shipped_windows):
    """The vectorised transform (product powers, precomputed taper and band matrix) agrees
    with the per-window scipy reference on real windows, in a batch and one window at a
    time (the serving path)."""
    from features.reference import reference_features

    for ws in shipped_windows:
        fx = WindowFeatures(channels=ws.channels, rate_hz=ws.rate_hz).fit(ws.X)
        some = ws.X[::25]
        ref = reference_features(some, ws.channels, ws.rate_hz)
        batch = fx.transform(some)
        single = np.concatenate([fx.transform(w[None]) for w in some])
        np.testing.assert_allclose(batch, ref, rtol=1e-9, atol=1e-9)
        np.testing.assert_array_equal(single, batch)   # batch size does not change a value
        # a window length other than the fitted one recomputes the helpers
        short = fx.transform(some[:, :, :150])
        fresh = WindowFeatures(channels=ws.channels, rate_hz=ws.rate_hz).fit(some[:, :, :150])
        np.testing.assert_array_equal(short, fresh.transform(some[:, :, :150]))


def test_band_weights_average_the_bins_of_each_band():
    W = calculators.band_weights(200, 100.0, ((0.0, 2.5), (2.5, 5.0), (7.01, 7.02)))
    assert W.shape == (101, 3)
    np.testing.assert_allclose(W.sum(axis=0), 1.0)
    assert np.count_nonzero(W[:, 0]) == 5          # 0, 0.5, ..., 2.0 Hz
    assert np.flatnonzero(W[:, 2]).tolist() == [14]  # empty band: nearest bin, 7.0 Hz


@pytest.mark.slow
def test_serial_feature_union_equals_feature_union(shipped_windows):
    """The serial union gives FeatureUnion's output bit for bit (weights and dropped parts
    included) and keeps its names, parameters and pickling."""
    import pickle

    from sklearn.pipeline import FeatureUnion

    from features.transformers import SerialFeatureUnion
    from features.wheel_physics import WheelPhysicsFeatures

    ws = shipped_windows[0]
    parts = lambda: [("stats", WindowFeatures(channels=ws.channels, rate_hz=ws.rate_hz)),  # noqa: E731
                     ("physics", WheelPhysicsFeatures(channels=ws.channels,
                                                      rate_hz=ws.rate_hz)),
                     ("off", "drop")]
    X = ws.X[:50]
    for weights in (None, {"stats": 2.0}):
        ref = FeatureUnion(parts(), transformer_weights=weights).fit(X)
        ser = SerialFeatureUnion(parts(), transformer_weights=weights).fit(X)
        assert np.array_equal(ser.transform(X), ref.transform(X))
        assert np.array_equal(ser.transform(X[:1]), ref.transform(X[:1]))
        assert list(ser.get_feature_names_out()) == list(ref.get_feature_names_out())
    again = pickle.loads(pickle.dumps(ser))
    assert np.array_equal(again.transform(X), ser.transform(X))
    assert clone(ser).get_params()["transformer_weights"] == {"stats": 2.0}
    # parallel settings go through FeatureUnion's own path, same result
    assert np.array_equal(SerialFeatureUnion(parts(), n_jobs=2).fit(X).transform(X),
                          FeatureUnion(parts(), n_jobs=2).fit(X).transform(X))


def test_serial_feature_union_runs_each_part_once_whatever_it_returns():
    """Parts with pandas output (``set_output``) or a passthrough part are stacked as
    FeatureUnion stacks them, and each part's transform still runs exactly once per call
    (it used to run everything a second time through FeatureUnion)."""
    import pandas as pd
    from sklearn.pipeline import FeatureUnion
    from sklearn.preprocessing import FunctionTransformer, StandardScaler

    from features.transformers import SerialFeatureUnion

    calls = []

    def counted(X):
        calls.append(len(X))
        return 2.0 * X

    X = np.random.default_rng(0).normal(size=(12, 3))
    parts = lambda: [("scale", StandardScaler()),  # noqa: E731
                     ("double", FunctionTransformer(counted, feature_names_out="one-to-one")),
                     ("raw", "passthrough"), ("off", "drop")]
    ref = FeatureUnion(parts()).set_output(transform="pandas").fit(X)
    ser = SerialFeatureUnion(parts()).set_output(transform="pandas").fit(X)
    calls.clear()
    got = ser.transform(X)
    assert calls == [12]
    assert isinstance(got, pd.DataFrame)
    pd.testing.assert_frame_equal(got, ref.transform(X))
    dense = SerialFeatureUnion(parts(), transformer_weights={"raw": 3.0}).fit(X)
    np.testing.assert_array_equal(
        dense.transform(X), FeatureUnion(parts(), transformer_weights={"raw": 3.0}).fit(X)
        .transform(X))
    assert SerialFeatureUnion([("off", "drop")]).fit(X).transform(X).shape == (12, 0)


def test_band_above_nyquist_is_refused_at_fit():
    fx = WindowFeatures(channels=("ax",), rate_hz=50.0, stats=("mean",),
                        bands_hz=((30.0, 40.0),))
    with pytest.raises(ConfigError, match="above the Nyquist frequency 25 Hz"):
        fx.fit(np.ones((1, 1, 100)))


@pytest.mark.parametrize("rate_hz, band_width_hz, match", [
    (50.0, -1.0, "band_width_hz"), (50.0, 0.0, "band_width_hz"),
    (50.0, np.nan, "band_width_hz"), (50.0, np.inf, "band_width_hz"),
    (50.0, "2.5", "band_width_hz"), (0.0, 2.5, "rate_hz"), (np.nan, 2.5, "rate_hz"),
])
def test_linear_bands_refuse_widths_and_rates_that_give_no_bands(
        rate_hz, band_width_hz, match):
    """A negative band width gave no band at all without a word (WindowFeatures then made
    no band feature), 0 raised ZeroDivisionError and NaN numpy's 'arange: cannot compute
    length'."""
    with pytest.raises(ConfigError, match=match):
        linear_bands(rate_hz, band_width_hz)
    with pytest.raises(ConfigError, match=match):
        WindowFeatures(channels=("ax",), rate_hz=rate_hz,
                       band_width_hz=band_width_hz).fit(np.ones((1, 1, 100)))
    if match == "rate_hz":   # given bands: band_weights checks the rate
        with pytest.raises(ConfigError, match=match):
            WindowFeatures(channels=("ax",), rate_hz=rate_hz,
                           bands_hz=((0.0, 2.0),)).fit(np.ones((1, 1, 100)))


@pytest.mark.parametrize("kw, match", [
    ({"channels": ("wz", "ax", "wz")}, r"channels \['wz'\] given twice.*wz__"),
    ({"channels": ("wz", "ax"), "stats": ("std", "mean", "std")},
     r"stats \['std'\] given twice\): names ax__std, wz__std"),
    ({"channels": ("ax",), "bands_hz": ((1.0, 2.0), (1.0000001, 2.0))},
     r"agree to 6 digits\): name ax__band_1_2hz"),
])
def test_repeated_feature_names_are_refused(kw, match):
    """A repeated channel or statistic gave repeated columns and names (channels ('wz',
    'ax', 'wz'): 27 names, 18 distinct), and two bands equal to 6 digits one name."""
    X = np.random.default_rng(0).normal(size=(2, len(kw["channels"]), 100))
    with pytest.raises(ConfigError, match=f"more than once.*{match}"):
        WindowFeatures(rate_hz=50.0, **kw).fit(X)


@pytest.mark.parametrize("seed", range(4))
def test_every_column_is_the_feature_its_name_says(seed):
    """Property over random channel subsets, statistics and bands: names are unique and
    column k is the named feature computed on its own."""
    rng = np.random.default_rng(seed)
    channels = tuple(rng.permutation(ALL_CHANNELS)[:rng.integers(1, len(ALL_CHANNELS))])
    stats = tuple(rng.permutation(DEFAULT_STATS)[:rng.integers(1, len(DEFAULT_STATS))])
    X = rng.normal(size=(3, len(channels), 64))
    fx = WindowFeatures(channels=channels, rate_hz=50.0, stats=stats, band_width_hz=5.0)
    F = fx.fit_transform(X)
    names = list(fx.get_feature_names_out())
    assert len(set(names)) == len(names) == F.shape[1]
    bands = {_band_name(lo, hi): (lo, hi) for lo, hi in linear_bands(50.0, 5.0)}
    for k, name in enumerate(names):
        signal_name, feature = name.split("__", 1)
        x = X[:, channels.index(signal_name)]
        if feature in calculators.STATISTICS:
            want = calculators.STATISTICS[feature](x)
        elif feature in bands:
            want = calculators.band_log_power(x[:, None], 50.0, (bands[feature],))[:, 0, 0]
        else:
            continue   # cross terms: test_columns_hold_what_their_names_say
        np.testing.assert_allclose(F[:, k], want, rtol=1e-12, err_msg=name)  # (BLAS order)


def test_one_sample_windows_are_refused_not_given_nan_features():
    """Windows of one sample passed the checks and gave a NaN <channel>__mean_abs_diff
    column for every channel (finite input, non-finite features)."""
    X = np.random.default_rng(0).normal(size=(2, 3, 1))
    fx = WindowFeatures(channels=("wz", "cur_l", "vel_l"), rate_hz=50.0)
    with pytest.raises(ValueError, match="at least 2 samples"):
        fx.fit(X)
    fx.fit(np.repeat(X, 2, axis=2))
    with pytest.raises(ValueError, match="at least 2 samples"):
        fx.transform(X)
    assert np.isfinite(fx.transform(np.repeat(X, 2, axis=2))).all()


@pytest.mark.parametrize("field", ["min_speed_m_s", "turn_floor_rad_s"])
@pytest.mark.parametrize("value", [0.0, -1.0, np.nan, np.inf, True, "0.05"])
def test_cross_term_floors_that_are_not_finite_positive_numbers_are_refused(field, value):
    """The floors keep the cross terms of a standing, straight window finite: a floor of 0
    (or negative) gave ``cur_l__per_speed`` inf and ``wz__gain_on_yaw_rate_wheels`` NaN
    (0/0) for finite windows, NaN gave NaN, and True was taken as 1."""
    X = np.zeros((2, 4, 100))
    X[:, 1] = 5.0                                     # 5 A at standstill, not turning
    fx = WindowFeatures(channels=("wz", "cur_l", "vel_l", "yaw_rate_wheels"), rate_hz=50.0,
                        **{field: value})
    with pytest.raises(ConfigError, match=f"WindowFeatures.{field} must be"):
        fx.fit(X)
    assert np.isfinite(WindowFeatures(channels=fx.channels, rate_hz=50.0).fit_transform(X)).all()


def test_a_band_width_in_the_wrong_unit_is_refused_before_any_band_is_built():
    """1e-6 Hz at 50 Hz built 25 million bands, each a feature of every channel; the cap
    is 10 000 bands."""
    from features.transformers import MAX_BANDS

    assert len(linear_bands(1000.0, 0.05)) == MAX_BANDS
    with pytest.raises(ConfigError, match="into 25000000 bands, more than 10000"):
        linear_bands(50.0, 1e-6)
    with pytest.raises(ConfigError, match="is the width in Hz"):
        WindowFeatures(channels=("ax",), rate_hz=50.0, band_width_hz=1e-6).fit(
            np.ones((1, 1, 100)))
