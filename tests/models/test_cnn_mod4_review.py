"""Review tests (mod4) of the window CNNs: typed refusals of settings and windows that trained
a useless network without a word, and the arithmetic of the standardisation, the band mask
and the class weights."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.signal import get_window
from test_cnn import FAST, RATE_HZ, _planted  # same folder (pytest's default prepend import)

from terrain.errors import ConfigError
from terrain.models.cnn import (POWER_FLOOR, RawCNNClassifier, SpectrogramCNNClassifier,
                                log_spectrogram, segment_samples)

ONE_EPOCH = {**FAST, "max_epochs": 1}


@pytest.mark.parametrize("std", [np.inf, -0.1, np.nan])
def test_a_noise_copy_of_infinite_or_negative_spread_is_a_config_error(std):
    """augment_noise_std=inf perturbed every copy by +-inf: the network trained on NaN losses
    and predicted NaN probabilities, without a word."""
    X, y, _ = _planted(n_runs=2, per_run=4)
    with pytest.raises(ConfigError, match="augment_noise_std"):
        SpectrogramCNNClassifier(**ONE_EPOCH, augment_noise_std=std).fit(X, y)


@pytest.mark.parametrize("limit", [np.nan, -1.0])
def test_a_band_limit_that_is_not_a_frequency_is_a_config_error(limit):
    """band_limits_hz (nan, ...) or (-1, ...) zeroed every bin of that channel (nothing is
    <= NaN or a negative frequency): the channel silently dropped out of the model."""
    X, y, _ = _planted(n_runs=2, per_run=4)
    with pytest.raises(ConfigError, match="band_limits_hz"):
        SpectrogramCNNClassifier(**ONE_EPOCH, band_limits_hz=(limit, 3.25, np.inf)).fit(X, y)
    # 0 Hz keeps the level (the 0 Hz bin) and inf every bin: both are limits
    model = SpectrogramCNNClassifier(**ONE_EPOCH, band_limits_hz=(0.0, 3.25, np.inf)).fit(X, y)
    assert model.mask_[0, :, 0].tolist() == [1.0] + [0.0] * 25 and model.mask_[2].all()


@pytest.mark.parametrize("cls", [RawCNNClassifier, SpectrogramCNNClassifier])
@pytest.mark.parametrize("shape", [(8, 3, 0), (8, 0, 200)])
def test_empty_windows_are_refused_with_a_value_error(cls, shape):
    """Windows of 0 samples or 0 channels reached torch or numpy (a RuntimeError about the
    kernel size or max_pool1d, 'Invalid number of FFT data points (0)')."""
    y = np.array(["A", "B"] * 4)
    with pytest.raises(ValueError, match=r"empty windows .* \(channels, samples\)"):
        cls(**ONE_EPOCH).fit(np.zeros(shape, dtype=np.float32), y)
    X, yy, _ = _planted(n_runs=2, per_run=4)
    model = cls(**ONE_EPOCH).fit(X, yy)
    with pytest.raises(ValueError, match=r"empty windows"):
        model.predict_proba(np.zeros((2,) + shape[1:], dtype=np.float32))


def test_a_silent_channel_sits_at_minus_ten_the_documented_power_floor():
    """log10(|STFT|^2 + 1e-10): a silent channel's every bin is -10, whatever the constant's
    name (the earlier test compares with log10(POWER_FLOOR), which follows any value)."""
    spec, _ = log_spectrogram(np.zeros((1, 2, 100), dtype=np.float32), RATE_HZ, 0.2, 0.1)
    np.testing.assert_allclose(spec, -10.0, rtol=1e-6)


@pytest.mark.parametrize("hop_s, hop", [(0.012, 1), (0.016, 2), (0.024, 2), (0.026, 3)])
def test_the_hop_is_the_nearest_whole_number_of_samples(hop_s, hop):
    """1.2 samples is a hop of 1 and 1.6 one of 2 (neither truncated nor rounded up)."""
    X = np.random.default_rng(0).normal(size=(1, 1, 200)).astype(np.float32)
    spec, _ = log_spectrogram(X, RATE_HZ, segment_s=0.29, hop_s=hop_s)
    assert spec.shape[-1] == (200 - 29) // hop + 1
    np.testing.assert_array_equal(spec[..., 1], log_spectrogram(
        X[..., hop:], RATE_HZ, segment_s=0.29, hop_s=hop_s)[0][..., 0])


def test_the_noise_copy_is_drawn_from_random_state():
    """The same seed draws the same copy, another seed another one."""
    Z = np.random.default_rng(1).normal(size=(20, 2, 26, 8)).astype(np.float32)
    y = np.arange(20) % 2

    def copy(seed):
        model = SpectrogramCNNClassifier(augment_noise_std=0.3, random_state=seed)
        model.mask_ = None
        return model._augmented(Z, y)[0][20:]

    np.testing.assert_array_equal(copy(4), copy(4))
    assert not np.allclose(copy(4), copy(5), atol=0.1)


def test_a_three_sample_segment_is_rectangular_and_a_four_sample_one_hann_tapered():
    """np.hanning(3) is [0, 1, 0], which left every bin of a 3-sample segment the middle
    sample's power (no spectrum): segments under 4 samples are rectangular (review mdl23);
    from 4 samples on the periodic Hann taper applies."""
    X = np.array([[[1.0, 2.0, 4.0, -3.0]]], dtype=np.float32)
    spec, freqs = log_spectrogram(X, RATE_HZ, segment_s=0.03, hop_s=0.01)
    assert spec.shape == (1, 1, 2, 2) and freqs.tolist() == pytest.approx([0.0, 100 / 3])
    for frame in range(2):
        power = np.abs(np.fft.rfft(X[0, 0, frame:frame + 3].astype(np.float64))) ** 2
        np.testing.assert_allclose(spec[0, 0, :, frame], np.log10(power + POWER_FLOOR),
                                   rtol=1e-6)
    spec, _ = log_spectrogram(X, RATE_HZ, segment_s=0.04, hop_s=0.01)
    power = np.abs(np.fft.rfft(X[0, 0].astype(np.float64) * get_window("hann", 4))) ** 2
    np.testing.assert_allclose(spec[0, 0, :, 0], np.log10(power + POWER_FLOOR), rtol=1e-5)


def test_weights_positive_only_on_the_early_stopping_runs_are_refused():
    """The validation runs take no part in the draws: weights > 0 on them only reached
    torch's RuntimeError 'invalid multinomial distribution (sum of probabilities <= 0)'."""
    X, y, groups = _planted(n_runs=8, per_run=4)
    settings = dict(ONE_EPOCH, early_stopping=True, validation_splits=4)
    held_out = RawCNNClassifier(**settings).fit(X, y, groups=groups).validation_groups_
    weights = np.isin(groups, held_out).astype(float)
    with pytest.raises(ValueError, match="sample_weight is 0 on every training window"):
        RawCNNClassifier(**settings).fit(X, y, groups=groups, sample_weight=weights)
    RawCNNClassifier(**settings).fit(X, y, groups=groups, sample_weight=1.0 - weights)


@pytest.mark.parametrize("cls", [RawCNNClassifier, SpectrogramCNNClassifier])
def test_boolean_windows_are_refused(cls):
    """A mask handed over for the signals (X > 0) trained and predicted on 0/1 values."""
    X, y, _ = _planted(n_runs=2, per_run=4)
    with pytest.raises(ValueError, match="windows hold booleans"):
        cls(**ONE_EPOCH).fit(X > 0, y)
    with pytest.raises(ValueError, match="windows hold booleans"):
        cls(**ONE_EPOCH).fit((X > 0).tolist(), y)
    model = cls(**ONE_EPOCH).fit(X, y)
    with pytest.raises(ValueError, match="windows hold booleans"):
        model.predict_proba(X[:2] > 0)


@pytest.mark.parametrize("cls", [RawCNNClassifier, SpectrogramCNNClassifier])
@pytest.mark.parametrize("setting, value", [("max_epochs", 0), ("max_epochs", True),
                                            ("n_threads", 0), ("n_threads", -1)])
def test_an_empty_epoch_budget_or_thread_count_is_a_config_error(cls, setting, value):
    """max_epochs=0 'fitted' without a single epoch (n_epochs_ 0) and predicted with the
    random initial weights; n_threads=0 silently kept torch's count, -1 reached torch's
    RuntimeError 'set_num_threads expects a positive integer'."""
    X, y, _ = _planted(n_runs=2, per_run=4)
    with pytest.raises(ConfigError, match=f"{setting} must be an integer >= 1, got {value}"):
        cls(**{**ONE_EPOCH, setting: value}).fit(X, y)


@pytest.mark.parametrize("cls", [RawCNNClassifier, SpectrogramCNNClassifier])
def test_a_numpy_integer_seed_trains_the_same_network_as_the_python_one(cls):
    """random_state=np.int64(3) (a seed from np.arange) raised TypeError 'an integer is
    required' from torch.Generator.manual_seed."""
    X, y, _ = _planted(n_runs=2, per_run=4)
    python = cls(**ONE_EPOCH, random_state=3).fit(X, y).predict_proba(X)
    np.testing.assert_array_equal(
        cls(**ONE_EPOCH, random_state=np.int64(3)).fit(X, y).predict_proba(X), python)


@pytest.mark.parametrize("seed", [None, -1, 2.0, True, 2 ** 32])
def test_a_seed_that_is_not_an_integer_in_numpys_range_is_a_config_error(seed):
    """None and 2.0 reached torch's TypeError / RuntimeError; -1 trained without early
    stopping or a noise copy and failed with them (numpy's 'Seed must be between 0 and
    2**32 - 1')."""
    X, y, _ = _planted(n_runs=2, per_run=4)
    with pytest.raises(ConfigError, match="random_state must be an integer in"):
        RawCNNClassifier(**ONE_EPOCH, random_state=seed).fit(X, y)


@pytest.mark.parametrize("cls", [RawCNNClassifier, SpectrogramCNNClassifier])
@pytest.mark.parametrize("width", [0, 8.0])
def test_a_network_width_that_is_not_a_positive_integer_is_a_config_error(cls, width):
    """width=0 reached torch's RuntimeError 'Given groups=1, expected weight to be at least 1
    at dimension 0 ...' from the first convolution."""
    X, y, _ = _planted(n_runs=2, per_run=4)
    with pytest.raises(ConfigError, match=f"width must be an integer >= 1, got {width}"):
        cls(**{**ONE_EPOCH, "width": width}).fit(X, y)


def test_a_one_sample_window_is_one_one_sample_segment():
    """The segment is at least 2 samples where the window has them; a 1-sample window (as
    scikit-learn's 1-feature check feeds) is one 1-sample segment: its power, one bin."""
    assert segment_samples(RATE_HZ, 0.001, 200) == 2 and segment_samples(RATE_HZ, 0.5, 1) == 1
    spec, freqs = log_spectrogram(np.full((1, 1, 1), 3.0, np.float32), RATE_HZ, 0.5, 0.2)
    assert spec.shape == (1, 1, 1, 1) and freqs.tolist() == [0.0]
    np.testing.assert_allclose(spec[0, 0, 0, 0], np.log10(9.0 + POWER_FLOOR), rtol=1e-6)
