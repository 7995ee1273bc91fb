"""Review tests (ftr21): feature calculators and the window-feature transformer."""

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from hypothesis.extra.numpy import arrays

from features import calculators
from features.transformers import WindowFeatures
from features.windows import ALL_CHANNELS
from terrain.errors import ConfigError

_X = np.random.default_rng(21).normal(size=(3, len(ALL_CHANNELS), 20))


@pytest.mark.parametrize("bands", [((0.0, 5.0, 7.0),), (("a", 5.0),), ((True, 5.0),),
                                   (5.0, 6.0), ((0.0, None),), "0-5"])
def test_band_weights_refuse_a_band_that_is_not_a_pair_of_numbers(bands):
    """A band of three edges, of text, of a boolean edge or a bare number: a ConfigError
    naming the band (was NumPy's unpacking / isfinite error, or True read as 1 Hz)."""
    with pytest.raises(ConfigError, match=r"bands_hz\[0\]"):
        calculators.band_weights(10, 50.0, bands)


@pytest.mark.parametrize("bands", [((0.0, 5.0, 7.0),), (("a", 5.0),), ((True, 5.0),),
                                   (5.0, 6.0)])
def test_window_features_refuse_malformed_bands_at_fit(bands):
    """The same bands as WindowFeatures settings: refused by fit, nothing set."""
    fx = WindowFeatures(bands_hz=bands)
    with pytest.raises(ConfigError, match=r"bands_hz\[0\]"):
        fx.fit(_X)
    assert not hasattr(fx, "feature_names_out_")


_finite = st.floats(-1e3, 1e3, allow_nan=False, width=64)


@settings(max_examples=60, deadline=None)
@given(arrays(np.float64, st.tuples(st.integers(1, 3), st.integers(2, 40)), elements=_finite))
def test_statistics_kernel_agrees_with_numpy(x):
    """The compiled one-pass statistics equal plain NumPy definitions on random windows."""
    got = calculators.statistics(x, calculators._STATISTIC_NAMES)
    mu = x.mean(axis=-1)
    d = x - mu[:, None]
    m2 = (d ** 2).mean(axis=-1)
    flat = m2 <= 1e-12
    safe = np.where(flat, 1.0, m2)
    skew = np.where(flat, 0.0, (d ** 3).mean(axis=-1) / safe ** 1.5)
    kurt = np.where(flat, 0.0, (d ** 4).mean(axis=-1) / safe ** 2 - 3.0)
    want = np.stack([mu, np.sqrt(m2), skew, kurt, np.sqrt((x ** 2).mean(axis=-1)),
                     x.min(axis=-1), x.max(axis=-1),
                     np.abs(np.diff(x, axis=-1)).mean(axis=-1)], axis=-1)
    scale = 1.0 + np.abs(x).max()
    tol = np.array([1e-9 * scale, 1e-7 * scale, 1e-5, 1e-5, 1e-9 * scale, 0.0, 0.0,
                    1e-9 * scale])
    assert np.all(np.abs(got - want) <= tol + 1e-6 * np.abs(want)), (got, want)


@settings(max_examples=40, deadline=None)
@given(st.integers(2, 64), st.floats(-1e3, 1e3), st.booleans())
def test_constant_window_gives_finite_features(n, value, zero):
    """A constant (or all-zero) window: every feature finite, moments 0 (no 0/0)."""
    x = np.full((1, len(ALL_CHANNELS), n), 0.0 if zero else value)
    fx = WindowFeatures().fit(x)
    out = fx.transform(x)
    assert out.shape == (1, len(fx.get_feature_names_out()))
    assert np.all(np.isfinite(out))


def _wheel_inputs(n_windows=2, n=12):
    rng = np.random.default_rng(3)
    return [rng.normal(size=(n_windows, n)) for _ in range(4)]


@pytest.mark.parametrize("k", range(4))
def test_physics_features_refuse_boolean_inputs(k):
    """A mask passed as a wheel speed or current (True read as 1 m/s or 1 A): refused
    naming the input (was silently converted)."""
    from features.wheel_physics import physics_features
    from terrain.errors import DataFormatError

    args = _wheel_inputs()
    args[k] = args[k] > 0
    name = ("vel_l", "vel_r", "cur_l", "cur_r")[k]
    with pytest.raises(DataFormatError, match=f"{name} must hold numbers"):
        physics_features(*args, rate_hz=10.0)


def test_physics_features_refuse_text_inputs():
    """Text among the currents: a DataFormatError naming the input (was NumPy's
    'could not convert string to float')."""
    from features.wheel_physics import physics_features
    from terrain.errors import DataFormatError

    args = _wheel_inputs()
    args[2] = np.array([["a"] * 12, ["b"] * 12])
    with pytest.raises(DataFormatError, match="cur_l must hold real numbers"):
        physics_features(*args, rate_hz=10.0)


@pytest.mark.parametrize("stat", sorted(calculators.STATISTICS))
def test_statistics_refuse_boolean_windows(stat):
    """A boolean mask given as windows: refused (was read as 0/1 samples)."""
    from terrain.errors import DataFormatError

    with pytest.raises(DataFormatError, match="x must hold numbers"):
        calculators.STATISTICS[stat](np.ones((2, 3, 5)) > 0)


def test_statistics_refuse_text_windows_and_text_names():
    """Text samples: a DataFormatError (was NumPy's conversion error); names given as one
    text: a ConfigError saying so (was 'unknown statistics ['m', 'e', 'a', 'n']')."""
    from terrain.errors import DataFormatError

    with pytest.raises(DataFormatError, match="x must hold real numbers"):
        calculators.statistics(np.array([["a", "b"]]), ("mean",))
    with pytest.raises(ConfigError, match="sequence of names"):
        calculators.statistics(np.ones((2, 4)), "mean")


def _slip_window():
    from features.slip_features import SLIP_CHANNELS

    rng = np.random.default_rng(5)
    x = rng.normal(size=(len(SLIP_CHANNELS), 20))
    x[list(SLIP_CHANNELS).index("az")] += 9.81
    return x, list(SLIP_CHANNELS)


def test_slip_features_refuse_a_channel_named_twice():
    """A window of 13 rows whose last is named cur_l again: the features read whichever
    came last, silently (WindowFeatures and WheelPhysicsFeatures refuse it): refused."""
    from features.slip_features import slip_feature_matrix, window_feature_vector
    from terrain.vehicles.skid_steer import HuskyParams

    x, ch = _slip_window()
    x2 = np.vstack([x, 5.0 + x[:1]])
    with pytest.raises(ConfigError, match="cur_l"):
        window_feature_vector(x2, ch + ["cur_l"], 20.0, HuskyParams())
    with pytest.raises(ConfigError, match="cur_l"):
        slip_feature_matrix(x2[None], ch + ["cur_l"], 20.0, HuskyParams())


def test_slip_feature_matrix_takes_nested_lists():
    """Windows given as nested lists: the same features as the array (was AttributeError
    'list' object has no attribute 'ndim')."""
    from features.slip_features import slip_feature_matrix
    from terrain.vehicles.skid_steer import HuskyParams

    x, ch = _slip_window()
    names, want = slip_feature_matrix(x[None], ch, 20.0, HuskyParams())
    names2, got = slip_feature_matrix(x[None].tolist(), ch, 20.0, HuskyParams())
    assert names == names2
    np.testing.assert_array_equal(got, want)


@pytest.mark.parametrize("n", [1, 50])
def test_add_ekf_channels_is_idempotent(n):
    """A frame that already holds the EKF channels (the step run twice): the same frame
    back, not ten duplicated ekf_* columns (frame['ekf_v_bx'] then a DataFrame)."""
    import pandas as pd

    from features.ekf_signals import EKF_CHANNELS, add_ekf_channels

    t = np.arange(n) * 0.02
    frame = pd.DataFrame({"t_s": t, "vel_l": 0.5 + 0.01 * np.sin(t), "vel_r": np.full(n, 0.6),
                          "wz": np.full(n, 0.1)})
    once = add_ekf_channels(frame)
    twice = add_ekf_channels(once)
    assert not twice.columns.duplicated().any()
    assert list(twice.columns) == list(frame.columns) + list(EKF_CHANNELS)
    pd.testing.assert_frame_equal(twice, once)


def test_slip_features_refuse_boolean_terrain_probabilities():
    """A terrain probability given as True (a mask of the terrain seen): refused naming the
    terrain (was read as probability 1)."""
    from features.slip_features import slip_feature_matrix, window_feature_vector
    from terrain.vehicles.skid_steer import HuskyParams

    x, ch = _slip_window()
    with pytest.raises(ConfigError, match="GRASS"):
        window_feature_vector(x, ch, 20.0, HuskyParams(), {"GRASS": True})
    with pytest.raises(ConfigError, match="GRASS"):
        slip_feature_matrix(x[None], ch, 20.0, HuskyParams(), {"GRASS": np.array([True])})


def test_window_ekf_channels_refuse_text_windows():
    """Text samples: a DataFormatError naming X (was NumPy's 'could not convert string to
    float')."""
    from features.ekf_signals import window_ekf_channels
    from terrain.errors import DataFormatError

    X = np.full((1, 3, 5), "a")
    with pytest.raises(DataFormatError, match="X must hold real numbers"):
        window_ekf_channels(X, ("vel_l", "vel_r", "wz"), 50.0)
