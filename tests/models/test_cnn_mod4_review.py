"""Review tests (mod4) of the window CNNs: typed refusals of settings and windows that trained
a useless network without a word, and the arithmetic of the standardisation, the band mask
and the class weights."""

from __future__ import annotations

import numpy as np
import pytest
from test_cnn import FAST, _planted  # same folder (pytest's default prepend import)

from terrain.errors import ConfigError
from terrain.models.cnn import RawCNNClassifier, SpectrogramCNNClassifier

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
