"""The CNNs' last partial minibatch at its boundary: one window (review mdl23).

A network in training mode normalises each batch over its windows and the positions the
convolutions leave; a window short enough that a batch normalisation sees one position
gives one value per channel when the batch holds one window, which torch refuses.
"""

from __future__ import annotations

import numpy as np
import pytest

from terrain.errors import ConfigError
from terrain.models.cnn import RawCNNClassifier, SpectrogramCNNClassifier

TINY = dict(max_epochs=1, width=2, n_threads=1, device="cpu")


def _windows(n_windows: int, n_samples: int, n_channels: int = 2):
    rng = np.random.default_rng(0)
    X = rng.normal(size=(n_windows, n_channels, n_samples)).astype(np.float32)
    y = np.array(["A", "B"] * n_windows)[:n_windows]
    return X, y


def _batch_sizes(model) -> list[int]:
    """Windows of every training batch of the last epoch."""
    return [b["train_batch_size"] for b in model.net_.history[-1, "batches"]]


@pytest.mark.parametrize("n_windows, batch_size", [(5, 4), (9, 4), (3, 2), (65, 64)])
def test_short_windows_with_a_last_batch_of_one_window_train(n_windows, batch_size):
    # 8 samples leave one position to the third normalisation of the raw network: a last
    # batch of one window failed with torch's bare "Expected more than 1 value per channel
    # when training"; it is now left out of the epoch (a different window each epoch)
    X, y = _windows(n_windows, 8)
    model = RawCNNClassifier(**TINY, batch_size=batch_size).fit(X, y)
    assert model.n_epochs_ == 1
    assert _batch_sizes(model) == [batch_size] * (n_windows // batch_size)
    assert model.predict_proba(X[:1]).shape == (1, 2)


def test_short_windows_with_a_last_batch_of_one_drawn_window_train():
    # the sampler path (sample_weight) draws n_windows windows too: same last batch
    X, y = _windows(5, 8)
    model = RawCNNClassifier(**TINY, batch_size=4).fit(X, y, sample_weight=np.arange(1, 6))
    assert _batch_sizes(model) == [4]


def test_spectrogram_network_with_a_last_batch_of_one_window_trains():
    # 2-sample segments and 2 frames pool to one position before the second normalisation
    X, y = _windows(5, 3)
    model = SpectrogramCNNClassifier(rate_hz=4.0, segment_s=0.5, hop_s=0.25, batch_size=2,
                                     **TINY).fit(X, y)
    assert _batch_sizes(model) == [2, 2]


@pytest.mark.parametrize("n_samples", [9, 16])
def test_longer_windows_keep_their_last_batch_of_one_window(n_samples):
    # 9 samples or more leave every normalisation two positions: a batch of one window
    # trains, and every window is trained on in every epoch, as before
    X, y = _windows(5, n_samples)
    model = RawCNNClassifier(**TINY, batch_size=4).fit(X, y)
    assert _batch_sizes(model) == [4, 1]


@pytest.mark.parametrize("n_windows", [5, 8])
def test_last_batches_of_two_windows_or_more_are_kept(n_windows):
    X, y = _windows(n_windows, 8)
    model = RawCNNClassifier(**TINY, batch_size=3).fit(X, y)
    assert _batch_sizes(model) == [3] * (n_windows // 3) + [n_windows % 3]


def test_batches_of_one_short_window_are_refused_by_name():
    # every batch holds one window: nothing could be dropped, torch's bare error came in
    # the first batch
    X, y = _windows(6, 8)
    model = RawCNNClassifier(**TINY, batch_size=1)
    with pytest.raises(ConfigError, match="batch_size"):
        model.fit(X, y)
    assert not hasattr(model, "net_")


def test_batches_of_one_longer_window_train():
    X, y = _windows(4, 9)
    model = RawCNNClassifier(**TINY, batch_size=1).fit(X, y)
    assert _batch_sizes(model) == [1, 1, 1, 1]
