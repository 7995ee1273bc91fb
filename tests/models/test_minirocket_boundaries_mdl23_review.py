"""MiniRocket at its boundaries: the shortest window, the fewest kernels (review mdl23)."""

from __future__ import annotations

import numpy as np
import pytest

pytest.importorskip("aeon")

from terrain.models.minirocket import (MIN_WINDOW_SAMPLES, MiniRocketFeatures,  # noqa: E402
                                       make_minirocket)


def _windows(n_samples: int, n_windows: int = 6) -> np.ndarray:
    return np.random.default_rng(0).normal(size=(n_windows, 2, n_samples)).astype(np.float32)


@pytest.mark.parametrize("n_samples", [4, 8])
def test_windows_shorter_than_the_kernels_are_refused_naming_their_length(n_samples):
    # aeon's own "n_timepoints must be >= 9 ... zero pad shorter series" came from inside
    # the fit of every fold; 4-8 samples are windows the windowing cuts (2 s at 4 Hz)
    with pytest.raises(ValueError, match=f"{n_samples} samples.*9 samples or more"):
        MiniRocketFeatures(n_kernels=84, max_dilations_per_kernel=4).fit(_windows(n_samples))


def test_one_channel_windows_as_2d_arrays_are_measured_along_their_samples():
    with pytest.raises(ValueError, match="8 samples"):
        MiniRocketFeatures(n_kernels=84).fit(_windows(8)[:, 0])


@pytest.mark.parametrize("n_samples", [9, 10])
def test_windows_of_nine_samples_or_more_are_transformed(n_samples):
    assert MIN_WINDOW_SAMPLES == 9
    X = _windows(n_samples)
    features = MiniRocketFeatures(n_kernels=84, max_dilations_per_kernel=4).fit(X)
    assert features.transform(X).shape == (6, 84)
    y = np.array(["a", "b", "c"] * 2)
    model = make_minirocket(n_kernels=84, max_dilations_per_kernel=4).fit(X, y)
    assert model.predict_proba(X[:1]).shape == (1, 3)


@pytest.mark.parametrize("n_kernels, n_features", [(1, 84), (83, 84), (84, 84), (167, 84),
                                                   (168, 168), (200, 168)])
def test_the_number_of_features_is_a_multiple_of_84_and_at_least_84(n_kernels, n_features):
    # documented: rounded down to a multiple of 84, and fewer than 84 asked give 84
    X = _windows(30)
    features = MiniRocketFeatures(n_kernels=n_kernels, max_dilations_per_kernel=4).fit(X)
    assert features.transform(X[:1]).shape == (1, n_features)


def _features(seed) -> np.ndarray:
    X = _windows(30)
    return MiniRocketFeatures(n_kernels=84, max_dilations_per_kernel=4,
                              random_state=seed).fit(X).transform(X)


@pytest.mark.parametrize("seed", [np.int64(3), np.uint32(3), np.int32(3)])
def test_a_numpy_integer_seed_is_the_seed_it_holds(seed):
    # aeon takes a seed only where isinstance(seed, int): a NumPy integer (a seed taken
    # from np.arange) was dropped and the biases drawn unseeded, so two fits differed
    np.testing.assert_array_equal(_features(seed), _features(3))


@pytest.mark.parametrize("seed", [2 ** 31 - 1, 2 ** 31, 2 ** 32 - 1])
def test_seeds_up_to_the_top_of_numpys_range_are_taken(seed):
    # aeon casts the seed to int32: 2**31 and above (valid split seeds, up to 2**32 - 1)
    # failed with a bare OverflowError; they are taken modulo 2**31 (documented)
    np.testing.assert_array_equal(_features(seed), _features(seed % 2 ** 31))


def test_seeds_below_2_31_keep_their_own_biases():
    assert not np.array_equal(_features(2 ** 31 - 1), _features(0))


@pytest.mark.parametrize("seed", [-1, 2 ** 32, 1.5, True, "0"])
def test_a_seed_outside_numpys_range_is_refused_by_name(seed):
    from terrain.errors import ConfigError

    with pytest.raises(ConfigError, match="random_state"):
        _features(seed)
