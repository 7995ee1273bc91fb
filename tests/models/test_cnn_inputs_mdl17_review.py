"""CNN settings and inputs refused by name (review mdl17)."""

from __future__ import annotations

import numpy as np
import pytest

from terrain.errors import ConfigError, NonFiniteInputError
from terrain.models.cnn import RawCNNClassifier

TINY = dict(max_epochs=4, width=2, batch_size=8, n_threads=1, device="cpu")


def _runs():
    rng = np.random.default_rng(0)
    X = rng.normal(size=(16, 2, 20)).astype(np.float32)
    y = np.array(["A", "B"] * 8)
    groups = np.array([f"run{i % 8}" for i in range(16)])
    return X, y, groups


@pytest.mark.parametrize("patience", [0, -1, 2.5, True, None])
def test_early_stopping_patience_not_a_whole_number_of_epochs_is_refused(patience):
    # skorch stops when its count of epochs without improvement *equals* the patience: 0
    # stopped every fit after its first epoch (a count reset to 0 by the first improvement),
    # -1 or 2.5 never stopped it (the budget ran whole with early stopping asked)
    X, y, groups = _runs()
    model = RawCNNClassifier(**TINY, early_stopping=True, validation_splits=2,
                             patience=patience)
    with pytest.raises(ConfigError, match="patience"):
        model.fit(X, y, groups=groups)


def test_a_patience_is_not_checked_without_early_stopping():
    X, y, _ = _runs()
    assert RawCNNClassifier(**TINY, patience=0).fit(X, y).n_epochs_ == 4


@pytest.mark.parametrize("weights", [np.array([True, False] * 8), [True, False] * 8,
                                     np.array(["1.0"] * 16)])
def test_sample_weights_of_booleans_or_text_are_refused_by_name(weights):
    # .astype(float) read a mask as weights 1 and 0 (half the windows never drawn) and text
    # "1.0" as the number 1
    X, y, _ = _runs()
    with pytest.raises(ValueError, match="sample_weight"):
        RawCNNClassifier(**TINY).fit(X, y, sample_weight=weights)


def test_numeric_sample_weights_are_taken():
    X, y, _ = _runs()
    weights = np.arange(1, 17)                          # integers: numbers
    assert RawCNNClassifier(**TINY).fit(X, y, sample_weight=weights).n_epochs_ == 4


@pytest.mark.parametrize("limits, said", [(3.25, "one frequency per channel"),
                                          ((True,), "numbers"), (("3",), "numbers")])
def test_band_limits_that_are_not_one_number_per_channel_are_refused_by_what_is_wrong(
        limits, said):
    # a bare 3.25 for one channel was refused as "band_limits_hz has 1 entries for 1
    # channels"; (True,) and ("3",) were read as limits of 1 Hz and 3 Hz
    from terrain.models.cnn import SpectrogramCNNClassifier

    X, y, _ = _runs()
    model = SpectrogramCNNClassifier(**TINY, segment_s=0.1, hop_s=0.05,
                                     band_limits_hz=limits)
    with pytest.raises(ConfigError, match=f"band_limits_hz.*{said}"):
        model.fit(X[:, :1], y)


@pytest.mark.parametrize("setting, value", [
    ("lr", -1e-3), ("lr", float("nan")), ("lr", True), ("lr", "3e-3"),
    ("weight_decay", -0.1), ("weight_decay", float("inf")),
    ("batch_size", 0), ("batch_size", 2.5), ("batch_size", True),
    ("dropout", 1.0), ("dropout", -0.1), ("dropout", float("nan"))])
def test_training_settings_are_refused_by_name_before_training(setting, value):
    # torch's and skorch's own errors came mid-fit, after the spectra and the scaling, in
    # their words (dropout NaN: a RuntimeError); lr=True was taken as a learning rate of 1
    X, y, _ = _runs()
    with pytest.raises(ConfigError, match=setting):
        RawCNNClassifier(**{**TINY, setting: value}).fit(X, y)


def test_a_missing_label_is_refused_by_index():
    # None beside text reached NumPy's bare TypeError "'<' not supported between instances
    # of 'NoneType' and 'str'" in np.unique
    X = np.random.default_rng(0).normal(size=(6, 2, 16))
    y = np.array(["A", "B", None, "A", "B", "A"], dtype=object)
    with pytest.raises(NonFiniteInputError, match="y holds 1 missing label.*index 2"):
        RawCNNClassifier(max_epochs=1).fit(X, y)
