"""Review tests (mod4) of the window CNNs: typed refusals of settings and windows that trained
a useless network without a word, and the arithmetic of the standardisation, the band mask
and the class weights."""

from __future__ import annotations

import numpy as np
import pytest
from test_cnn import FAST, _planted  # same folder (pytest's default prepend import)

from terrain.errors import ConfigError
from terrain.models.cnn import SpectrogramCNNClassifier

ONE_EPOCH = {**FAST, "max_epochs": 1}


@pytest.mark.parametrize("std", [np.inf, -0.1, np.nan])
def test_a_noise_copy_of_infinite_or_negative_spread_is_a_config_error(std):
    """augment_noise_std=inf perturbed every copy by +-inf: the network trained on NaN losses
    and predicted NaN probabilities, without a word."""
    X, y, _ = _planted(n_runs=2, per_run=4)
    with pytest.raises(ConfigError, match="augment_noise_std"):
        SpectrogramCNNClassifier(**ONE_EPOCH, augment_noise_std=std).fit(X, y)
